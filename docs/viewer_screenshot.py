"""Write docs/viewer.png, the README's picture of the 3D viewer: the gallery's arm imported
from MJCF (its parallelogram closed by a ``connect``), drawn with the file's geoms,
opened in headless Chromium.

    python docs/viewer_screenshot.py   (needs playwright and Debian's chromium)
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from PIL import Image
from playwright.sync_api import sync_playwright

from dalembert.examples import load
from dalembert.plotting import view

EXAMPLE, T_END, SHOWN_AT = "imported-linkage", 5.0, 2.5
OUT = Path(__file__).with_name("viewer.png")

example = load(EXAMPLE)
system = example.build()
traj = system.simulate((0, T_END), **example.INITIAL, t_eval=np.linspace(0, T_END, 401))
with tempfile.TemporaryDirectory() as folder:
    page_path = view(traj, system, Path(folder) / "viewer.html",
                     title=f"{EXAMPLE}: {example.TITLE}")
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path="/usr/bin/chromium",
            args=["--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        page = browser.new_page(viewport={"width": 1000, "height": 560})
        page.goto(page_path.as_uri())
        page.wait_for_function("window.dalembertViewer && window.dalembertViewer.ready")
        page.evaluate(f"window.dalembertViewer.setPlaying(false); "
                      f"window.dalembertViewer.show({SHOWN_AT})")
        page.wait_for_timeout(300)
        page.screenshot(path=str(OUT))
        browser.close()
# a palette of 128 colours keeps the PNG small
Image.open(OUT).convert("RGB").quantize(128).save(OUT, optimize=True)
print(f"wrote {OUT} ({OUT.stat().st_size // 1024} KB)")
