"""Shadows in one sonar frame: segmentation, pairing highlights with shadows, measuring shadow edges."""

