"""MAVFTP: no file server in the simulator, so every request is refused at once.

ArduSub 4.5 serves MAVFTP (``GCS_MAVLINK::handle_file_transfer_protocol``, GCS_FTP.cpp),
and MAVProxy reads parameters through ``@PARAM/param.pck`` first. A vehicle that stays
silent costs MAVProxy about 11 s of retries before it falls back to PARAM_REQUEST_LIST;
a NAK makes it fall back at once (``mavproxy_ftp.py`` ``handle_open_RO_reply`` treats any
non-ACK as failure). The reply follows MAVFTP's header: seq = request seq + 1, the same
session, opcode 129 (Nack), size 1, req_opcode = the request's opcode, data[0] =
ERR_FileNotFound (10) for OpenFileRO, else ERR_UnknownCommand (7).
"""

from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mavlink

OP_OPEN_FILE_RO = 4
OP_NACK = 129
ERR_UNKNOWN_COMMAND = 7
ERR_FILE_NOT_FOUND = 10
PAYLOAD_BYTES = 251


def ftp_nak(msg: mavlink.MAVLink_message) -> mavlink.MAVLink_message:
    """The NAK answering one FILE_TRANSFER_PROTOCOL request."""
    req = bytes(msg.payload)
    seq = int.from_bytes(req[0:2], "little")
    session, opcode = req[2], req[3]
    reply = bytearray(PAYLOAD_BYTES)
    reply[0:2] = ((seq + 1) % 65536).to_bytes(2, "little")
    reply[2] = session
    reply[3] = OP_NACK
    reply[4] = 1  # payload size
    reply[5] = opcode  # req_opcode
    reply[12] = ERR_FILE_NOT_FOUND if opcode == OP_OPEN_FILE_RO else ERR_UNKNOWN_COMMAND
    return mavlink.MAVLink_file_transfer_protocol_message(0, msg.get_srcSystem(), msg.get_srcComponent(),
                                                          list(reply))
