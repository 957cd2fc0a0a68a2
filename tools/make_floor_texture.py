"""Regenerate assets/textures/floor_tile.png, the floor texture (run once; the PNG is committed).

One tile covers 4 m x 4 m: 1 m grid lines, 0.25 m fine lines, a coloured patch per metre
square and a marker in one corner, so a camera looking down sees motion and which way it goes.
"""

from pathlib import Path

import cv2
import numpy as np

PIXELS = 512  # per 4 m tile: 128 px per metre
OUT = Path(__file__).resolve().parent.parent / "assets" / "textures" / "floor_tile.png"


def main() -> None:
    img = np.zeros((PIXELS, PIXELS, 3), np.uint8)
    per_m = PIXELS // 4
    palette = [(96, 140, 92), (120, 150, 100), (88, 128, 110), (130, 138, 96)]  # grass-like, BGR
    for i in range(4):
        for j in range(4):
            img[i * per_m : (i + 1) * per_m, j * per_m : (j + 1) * per_m] = palette[(i + 2 * j) % 4]
    for k in range(0, PIXELS, per_m // 4):
        cv2.line(img, (k, 0), (k, PIXELS - 1), (70, 90, 70), 1)
        cv2.line(img, (0, k), (PIXELS - 1, k), (70, 90, 70), 1)
    for k in range(0, PIXELS, per_m):
        cv2.line(img, (k, 0), (k, PIXELS - 1), (235, 235, 235), 3)
        cv2.line(img, (0, k), (PIXELS - 1, k), (235, 235, 235), 3)
    for i in range(4):
        for j in range(4):
            cx, cy = j * per_m + per_m // 2, i * per_m + per_m // 2
            cv2.circle(img, (cx, cy), 10 + 4 * ((i * 4 + j) % 4), (40, 60 + 40 * i, 200 - 40 * j), -1)
    cv2.putText(img, "N", (18, 60), cv2.FONT_HERSHEY_SIMPLEX, 1.6, (20, 20, 200), 4)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(OUT), img)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
