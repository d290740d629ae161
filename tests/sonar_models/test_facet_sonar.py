"""Physics and format checks of the facet sonar model (pytest; small frames, a few seconds)."""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from tests.sonar_models import facet_sonar as fs

SB = fs.Seabed(depth_m=10.0)
POSE = fs.SonarPose(0.0, 0.0, 9.0, heading_deg=0.0, tilt_deg=25.0)   # 1 m above the seabed


def _box_scene(yaw=30.0, refl=-10.0, h=0.1):
    return fs.Scene(SB, (fs.Target("box", 2.0, 0.0, 0.30, 0.20, h, yaw_deg=yaw, reflectivity_db=refl),))


def _lin_mean_db(a_db):
    return 10 * np.log10(np.mean(10 ** (np.asarray(a_db, float) / 10)))


@pytest.fixture(scope="module")
def box_frame():
    st = fs.FrameSettings(window=fs.Window(1.8, 1.0, 700), dtype="float32_db")
    return fs.render_frame(_box_scene(), POSE, st, rng=11)


def test_shadow_is_where_geometry_says(box_frame):
    fr, tr = box_frame
    img, r = fr["image"], fr["range_m"]
    t = tr["targets"][0]
    assert t["shadow_ok"]
    prof = t["shadow_profile"]
    assert len(prof) > 20
    inner = prof[4:-4]                       # keep away from the shadow's side edges
    sh, bg_behind, bg_side = [], [], []
    for p in inner:
        j = p["beam"]
        m = (r > p["r_top_m"] + 0.01) & (r < p["r_shadow_end_m"] - 0.01)
        sh.append(img[m, j])
        m2 = (r > p["r_shadow_end_m"] + 0.02) & (r < p["r_shadow_end_m"] + 0.12)
        bg_behind.append(img[m2, j])
        bg_side.append(img[m, max(prof[0]["beam"] - 8, 0)])
    s_db = _lin_mean_db(np.concatenate(sh))
    assert s_db < _lin_mean_db(np.concatenate(bg_behind)) - 12
    assert s_db < _lin_mean_db(np.concatenate(bg_side)) - 12
    # the target's top is brighter than the seabed, then the shadow starts at r_top
    nb = t["nearest_beam"]
    j = nb["beam"]
    top = (r > nb["r_top_m"] - 0.06) & (r < nb["r_top_m"] - 0.01)
    assert _lin_mean_db(img[top, j]) > _lin_mean_db(np.concatenate(bg_behind)) + 3


def test_similar_triangles_in_truth():
    cases = [
        (SB, POSE),
        (SB, fs.SonarPose(0.0, 0.0, 9.2, heading_deg=10.0, pitch_deg=4.0, roll_deg=-6.0, tilt_deg=30.0)),
        (fs.Seabed(depth_m=10.0, slope_north=0.05, slope_east=-0.03),
         fs.SonarPose(0.0, 0.0, 9.0, heading_deg=0.0, pitch_deg=-2.0, roll_deg=3.0, tilt_deg=24.0)),
    ]
    for sb, pose in cases:
        for yaw in (0.0, 25.0, 60.0, 90.0):
            sc = fs.Scene(sb, (fs.Target("box", 2.0, 0.1, 0.25, 0.12, 0.08, yaw_deg=yaw),))
            tr = fs.frame_truth(sc, pose)
            H = tr["altitude_perp_m"]
            t = tr["targets"][0]
            h = t["height_m"]
            # through the centre (and on inner beams) the far top edge casts the shadow
            for rec in [t, t["nearest_beam"]] + t["shadow_profile"][2:-2]:
                assert rec["r_shadow_end_m"] == pytest.approx(rec["r_top_m"] * H / (H - h), rel=1e-7)
                assert rec["height_contact_m"] == pytest.approx(h, abs=1e-7)
            # a beam that only clips a corner (tilted beam plane) may be shadowed by a
            # lower point of a side face; the relation holds with that point's height
            for rec in t["shadow_profile"]:
                hc = rec["height_contact_m"]
                assert 0 < hc <= h + 1e-9
                assert rec["r_shadow_end_m"] == pytest.approx(rec["r_top_m"] * H / (H - hc), rel=1e-7)


@pytest.mark.parametrize("kind", ["pipe", "post", "dome", "sphere", "rock"])
def test_similar_triangles_other_kinds(kind):
    t = fs.Target(kind, 2.0, 0.0, 0.3, 0.2, 0.12, yaw_deg=40.0, vertical_semi_axis_m=0.15, shape_seed=3)
    tr = fs.frame_truth(fs.Scene(SB, (t,)), POSE)
    H = tr["altitude_perp_m"]
    d = tr["targets"][0]
    assert d["height_m"] == pytest.approx(0.12)
    for rec in [d] + d["shadow_profile"]:
        hc = rec["height_contact_m"]
        assert 0 < hc <= d["height_m"] + 1e-9
        assert rec["r_shadow_end_m"] == pytest.approx(rec["r_top_m"] * H / (H - hc), rel=1e-7)


def _speckle_ratio(looks, model="gaussian", seed=4):
    st = fs.FrameSettings(window=fs.Window(2.1, 0.3, 300), dtype="float32", n_looks=looks, db_range=300)
    sp = fs.SonarParams(noise_db=-60.0, amplitude_model=model)
    fr, _ = fs.render_frame(fs.Scene(SB, ()), POSE, st, sp, rng=seed, return_linear=True)
    I = fr["linear_intensity"][20:280, 10:118]
    I = I / I.mean(axis=1, keepdims=True)           # remove the slow trend with range
    A = np.sqrt(I)
    return A.std() / A.mean()


def test_rayleigh_speckle_and_looks():
    r1 = _speckle_ratio(1)
    assert r1 == pytest.approx(math.sqrt(4 / math.pi - 1), abs=0.03)     # 0.523
    r4 = _speckle_ratio(4)
    assert r4 < r1 * 0.6
    assert _speckle_ratio(1, model="phase") == pytest.approx(0.523, abs=0.04)


def test_k_texture_is_heavier_tailed():
    st = fs.FrameSettings(window=fs.Window(2.1, 0.3, 300), dtype="float32", db_range=300)
    sb = fs.Seabed(depth_m=10.0, texture_shape=1.5, texture_scale_m=0.03)
    fr, _ = fs.render_frame(fs.Scene(sb, ()), POSE, st, fs.SonarParams(noise_db=-60), rng=5, return_linear=True)
    I = fr["linear_intensity"][20:280, 10:118]
    A = np.sqrt(I / I.mean(axis=1, keepdims=True))
    assert A.std() / A.mean() > 0.6


def test_tvg_off_seabed_decays_with_range():
    st = fs.FrameSettings(window=fs.Window(2.0, 1.2, 400), dtype="float32_db", tvg="none")
    fr, tr = fs.render_frame(fs.Scene(SB, ()), POSE, st, rng=6)
    img, r = fr["image"], fr["range_m"]
    near = _lin_mean_db(img[(r > 2.05) & (r < 2.25)])
    far = _lin_mean_db(img[(r > 2.85) & (r < 3.05)])
    assert near - far > 6.0
    st30 = fs.FrameSettings(window=fs.Window(2.0, 1.2, 400), dtype="float32_db", tvg="30log")
    fr30, _ = fs.render_frame(fs.Scene(SB, ()), POSE, st30, rng=6)
    d30 = _lin_mean_db(fr30["image"][(r > 2.05) & (r < 2.25)]) - _lin_mean_db(fr30["image"][(r > 2.85) & (r < 3.05)])
    assert d30 < near - far - 3.0


@pytest.mark.parametrize("dtype", ["uint8", "uint16", "float32"])
def test_file_keys_dtypes_shapes(tmp_path, dtype):
    st = fs.FrameSettings(window=fs.Window(1.9, 0.6, 257), dtype=dtype, timestamp_s=12.5)
    fr, tr = fs.render_frame(_box_scene(), POSE, st, rng=7)
    p = tmp_path / f"f_{dtype}.npz"
    fs.write_frame_npz(p, fr, known=("altitude_m", "tilt_deg", "vehicle_pitch_deg"))
    with np.load(p) as z:
        keys = set(z.files)
        assert keys == set(fs.REQUIRED_KEYS) | {"altitude_m", "tilt_deg", "vehicle_pitch_deg"}
        assert z["image"].shape == (257, 128) and z["image"].dtype == np.dtype(dtype)
        assert z["range_m"].shape == (257,) and z["range_m"].dtype == np.float64
        assert z["beam_azimuth_deg"].shape == (128,) and z["beam_azimuth_deg"].dtype == np.float64
        assert np.all(np.diff(z["range_m"]) > 0) and z["range_m"][0] == pytest.approx(1.9)
        assert np.all(np.diff(z["beam_azimuth_deg"]) > 0)
        for k in ("elevation_aperture_deg", "timestamp_s", "altitude_m", "tilt_deg", "vehicle_pitch_deg"):
            assert z[k].shape == () and z[k].dtype == np.float64
        assert float(z["elevation_aperture_deg"]) == 14.0
        assert float(z["timestamp_s"]) == 12.5
        assert float(z["altitude_m"]) == pytest.approx(1.0)
    fs.read_frame_npz(p)
    json.dumps(tr)                                   # truth is plain JSON


def test_all_optional_keys_and_reported_attitude(tmp_path):
    pose = fs.SonarPose(1.0, 2.0, 9.0, heading_deg=30.0, pitch_deg=3.0, roll_deg=-2.0, tilt_deg=25.0)
    st = fs.FrameSettings(window=fs.Window(1.5, 0.5, 200))
    fr, tr = fs.render_frame(fs.Scene(SB, ()), pose, st, rng=1, report={"vehicle_pitch_deg": 0.0})
    p = tmp_path / "all.npz"
    fs.write_frame_npz(p, fr)
    with np.load(p) as z:
        assert set(z.files) == set(fs.REQUIRED_KEYS) | set(fs.OPTIONAL_KEYS)
        assert float(z["vehicle_pitch_deg"]) == 0.0          # reported
        assert float(z["vehicle_roll_deg"]) == -2.0
        assert float(z["heading_deg"]) == 30.0
    assert tr["true_pose"]["pitch_deg"] == 3.0                # truth keeps the true value


def test_aris_beam_table():
    az = fs.aris3000_beam_azimuths_deg()
    assert az.shape == (128,) and np.all(np.diff(az) > 0)
    assert az[0] == pytest.approx(-15.0156) and az[-1] == pytest.approx(15.0068)


def test_determinism_with_seed():
    st = fs.FrameSettings(window=fs.Window(1.9, 0.5, 300))
    a, ta = fs.render_frame(_box_scene(), POSE, st, rng=42)
    b, tb = fs.render_frame(_box_scene(), POSE, st, rng=42)
    c, _ = fs.render_frame(_box_scene(), POSE, st, rng=43)
    assert np.array_equal(a["image"], b["image"])
    assert json.dumps(ta) == json.dumps(tb)
    assert not np.array_equal(a["image"], c["image"])
    p1 = fs.sample_pair(np.random.default_rng(9), render=False)
    p2 = fs.sample_pair(np.random.default_rng(9), render=False)
    assert p1["plan"] == p2["plan"] and p1["settings"] == p2["settings"]


def test_sample_pair_shadows_in_view_both_altitudes():
    rng = np.random.default_rng(2024)
    for _ in range(6):
        res = fs.sample_pair(rng, render=False, vary_dtype=True)
        plan = res["plan"]
        H = [tr["altitude_perp_m"] for tr in res["truth"]]
        assert H[1] - H[0] == pytest.approx(plan.info["delta_h_m"])
        assert 0.05 <= H[1] - H[0] <= 0.3 and 0.4 <= H[0] <= 1.5
        assert plan.poses[0].north_m == plan.poses[1].north_m
        assert 1 <= len(plan.scene.targets) <= 3
        for tr in res["truth"]:
            for t in tr["targets"]:
                assert t["shadow_ok"], t
                assert 0.02 <= t["height_m"] <= 0.30
        w0, w1 = (s.window for s in res["settings"])
        assert w0 != w1


def test_sound_speed_error_scales_reported_ranges():
    st = fs.FrameSettings(window=fs.Window(1.8, 1.0, 10), sound_speed_true_mps=1480.0,
                          sound_speed_reported_mps=1500.0)
    t = fs.frame_truth(_box_scene(), POSE, st)["targets"][0]
    assert t["r_top_reported_m"] == pytest.approx(t["r_top_m"] * 1500 / 1480)


def test_paper_targets():
    sets = fs.paper_targets(orientation_deg=20.0)
    assert len(sets) == 5
    for s, (L, W, H) in zip(sets, fs.PAPER_TABLE_I_CM):
        (t,) = s["plan"].scene.targets
        assert (t.kind, t.length_m, t.width_m, t.height_m) == ("box", L / 100, W / 100, H / 100)
        tr = [fs.frame_truth(s["plan"].scene, p, st) for p, st in zip(s["plan"].poses, s["settings"])]
        assert tr[1]["altitude_perp_m"] - tr[0]["altitude_perp_m"] == pytest.approx(0.1)
        assert all(x["targets"][0]["shadow_ok"] for x in tr)
        # the higher image has the shorter shadow
        assert tr[1]["targets"][0]["shadow_length_m"] < tr[0]["targets"][0]["shadow_length_m"]


def test_occlusion_hides_target_behind_target():
    # a short bright post inside a box's shadow: its echo must vanish
    box = fs.Target("box", 2.0, 0.0, 0.2, 0.2, 0.15, reflectivity_db=-10)
    post = fs.Target("post", 2.22, 0.0, 0.06, 0.06, 0.06, reflectivity_db=0.0, target_id=1)
    st = fs.FrameSettings(window=fs.Window(1.8, 1.0, 500), dtype="float32", db_range=300)
    sp = fs.SonarParams(noise_db=-60)
    alone, _ = fs.render_frame(fs.Scene(SB, (post,)), POSE, st, sp, rng=3, return_linear=True)
    both, _ = fs.render_frame(fs.Scene(SB, (box, post)), POSE, st, sp, rng=3, return_linear=True)
    r = alone["range_m"]
    m = (r > 2.37) & (r < 2.47)
    assert both["linear_intensity"][m, 60:68].sum() < 0.2 * alone["linear_intensity"][m, 60:68].sum()


def test_write_pair_files(tmp_path):
    res = fs.sample_pair(np.random.default_rng(3), n_targets=1, n_samples_range=(300, 400))
    out = fs.write_pair_files(res, tmp_path, known=("altitude_m", "sonar_depth_m"))
    doc = json.loads(Path(out["truth"]).read_text())
    assert len(doc["truth"]) == 2 and doc["truth"][1]["altitude_perp_m"] > doc["truth"][0]["altitude_perp_m"]
    for p, st in zip(out["frames"], res["settings"]):
        z = fs.read_frame_npz(p)
        assert z["image"].shape == (st.window.n_samples, 128)
        assert set(z) == set(fs.REQUIRED_KEYS) | {"altitude_m", "sonar_depth_m"}
