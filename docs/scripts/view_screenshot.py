"""docs/figures/view_nadir_wheels_dumping.png: the README's screenshot of `attitude view`.

Run from the repository root: ``python docs/scripts/view_screenshot.py`` (about a minute: the
day of nadir pointing is run first). It is exactly

    attitude run scenarios/nadir_wheels_dumping.toml && attitude view nadir_wheels_dumping.nc

then the page opened in the system's Chromium (through Playwright, the network blocked), set to
the sunlit frame of the next two hours after 5 h whose Sun is most behind the camera (LVLH), and
photographed.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from playwright.sync_api import sync_playwright

from attitude import cli

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "docs/figures/view_nadir_wheels_dumping.png"
ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]  # fmt: skip


FRAME_LIT_FROM_THE_CAMERA = """() => {
  const v = window.attitudeView;
  let best = 300, dot = -2;
  for (let i = 300; i < 420; i += 2) {
    const s = v.state(v.setFrame(i));
    const c = s.cameraPosition, n = Math.hypot(...c);
    const d = (s.sun[0] * c[0] + s.sun[1] * c[1] + s.sun[2] * c[2]) / n;
    if (s.lit === 1 && d > dot) { dot = d; best = i; }
  }
  v.setFrame(best);
  return best;
}"""


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        nc, html = Path(tmp) / "nadir_wheels_dumping.nc", Path(tmp) / "view.html"
        assert cli.main(["run", str(ROOT / "scenarios/nadir_wheels_dumping.toml"), "-o", str(nc),
                         "-q"]) == 0  # fmt: skip
        assert cli.main(["view", str(nc), "-o", str(html)]) == 0
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
            page = browser.new_page(viewport={"width": 1400, "height": 780})
            page.route("**/*", lambda r: r.abort() if r.request.url.startswith("http") else
                       r.continue_())  # fmt: skip
            page.goto(html.as_uri())
            page.wait_for_function("window.attitudeView && window.attitudeView.ready")
            # the first sunlit frame after 5 h with the Sun behind the camera: its lit side
            page.evaluate(FRAME_LIT_FROM_THE_CAMERA)
            page.screenshot(path=str(OUT))
            browser.close()
    print(OUT)


if __name__ == "__main__":
    main()
