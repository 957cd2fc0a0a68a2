"""Sensors: the onboard cameras (specs, intrinsics, rendering, render workers)."""
