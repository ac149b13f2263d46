"""Regenerate docs/view.png, the README's picture of ``slideplan view`` on the demo plan.

Plans the demo (``slideplan demo``'s crescent, seed 0), serves its view, opens it in Debian's
headless Chromium (Playwright, software WebGL), moves the time slider to the end of the slide and
takes a screenshot::

    PYTHONPATH=python python docs/make_view_screenshot.py [--out docs/view.png] [--time S] [--scene S --object O --seed N]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from playwright.sync_api import sync_playwright

from slideplan.cli.common import _load_object
from slideplan.plan.config import PlannerConfig
from slideplan.plan.planner import plan
from slideplan.world.scenes import load_scene
from slideplan.outputs.view3d import open_view

RENDER_WAIT_MS = 12000  # software WebGL needs this long for the first frame of the full scene


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "view.png")
    parser.add_argument("--time", type=float, default=None, help="plan time to show (s); default: the end of the slide")
    parser.add_argument("--scene", default="square", help="scene (default: the demo's)")
    parser.add_argument("--object", default="crescent", help="object at a seeded random pose (default: the demo's)")
    parser.add_argument("--seed", type=int, default=0, help="pose and planner seed (default: the demo's)")
    args = parser.parse_args()

    scene = load_scene(args.scene)
    obj, _ = _load_object(scene, args.object, None, args.seed)
    result = plan(scene, obj, PlannerConfig.for_scene(scene, seed=args.seed))
    view = open_view(result, port=0)
    try:
        view.slider.value = args.time if args.time is not None else round(view.segments[0].times[-1], 2)
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(
                executable_path="/usr/bin/chromium", headless=True,
                args=["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"],
            )
            page = browser.new_page(viewport={"width": 1200, "height": 800})
            page.goto(view.url)
            page.add_style_tag(content=".mantine-Notifications-root { display: none !important; }")
            page.wait_for_timeout(RENDER_WAIT_MS)
            page.screenshot(path=str(args.out))
            browser.close()
    finally:
        view.server.stop()
    print(args.out)


if __name__ == "__main__":
    main()
