"""Draw the template body from the front, the side and the back to ``docs/template.png``
(run from the repository root: ``.venv/bin/python data/body/render_template.py``)."""

from __future__ import annotations

import cv2
import numpy as np

from hullcap import BodyModel
from hullcap._cameras import Camera, look_at
from hullcap._render import shade


def main(out="docs/template.png"):
    model = BodyModel.template()
    pose = model.pose(root_translation=(0, 0, model.rest_root_height))
    w, h = 420, 600
    K = [[1500, 0, (w - 1) / 2], [0, 1500, (h - 1) / 2], [0, 0, 1]]
    panels = []
    for label, eye in (("front", (0, -6, 0.9)), ("side (left)", (6, 0, 0.9)), ("back", (0, 6, 0.9))):
        R, t = look_at(eye, (0, 0, 0.88))
        img, _ = shade(Camera(label, w, h, K, np.zeros(5), R, t), pose.vertices, model.faces)
        img = (img[..., ::-1] * 255).astype(np.uint8)
        joints_px, _ = Camera(label, w, h, K, np.zeros(5), R, t).project(pose.joints)
        for p in joints_px:
            cv2.circle(img, tuple(int(round(c)) for c in p), 3, (40, 40, 200), -1, cv2.LINE_AA)
        cv2.putText(img, label, (10, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (60, 60, 60), 1, cv2.LINE_AA)
        panels.append(img)
    cv2.imwrite(out, np.hstack(panels))
    print(f"{out}: {len(model.vertices)} vertices; joint centres drawn in red")


if __name__ == "__main__":
    main()
