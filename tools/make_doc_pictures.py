"""The documentation's pictures, made from the simulator itself: what the two onboard cameras see
a few seconds into the square scenario, side by side (docs/img/cameras.png). Run from the clone:
`python tools/make_doc_pictures.py`; tests/test_docs.py checks the picture is there and not blank."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from quadsim import CameraMode, Cameras, SimConfig, Simulator, Twist
from quadsim.sensors.camera import default_cameras

OUT = Path(__file__).resolve().parents[1] / "docs" / "img" / "cameras.png"


def main() -> None:
    specs = default_cameras(480, 360, 30)
    with Simulator(SimConfig()) as sim:
        cameras = Cameras(sim, specs, mode=CameraMode.SYNC)
        sim.send(Twist(linear_z=1.0))
        sim.run_for(1.6)  # up to about 1.5 m, facing the red tower 6 m ahead
        sim.send(Twist(linear_x=1.0))
        sim.run_for(1.5)  # toward it
        sim.send(Twist())
        sim.run_for(1.0)
        frames = [cameras.latest(spec.name) for spec in specs]
        cameras.close()
    images = [cv2.cvtColor(f.rgb, cv2.COLOR_RGB2BGR) for f in frames if f is not None]
    gap = np.full((images[0].shape[0], 8, 3), 255, np.uint8)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(OUT), np.hstack([images[0], gap, images[1]]))
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
