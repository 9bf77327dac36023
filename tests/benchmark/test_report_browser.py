"""report.html in a real browser (headless Chromium): every image loads, the page logs no error, the
table sorts on a header click, and a screenshot is not blank.

Chromium is driven from the command line, no Python package: ``--dump-dom`` of a copy of the page
with a probe script that records what it finds into the DOM, and ``--screenshot``. Without a
``chromium`` on the PATH the test is skipped, unless ``INPAINTENV_REQUIRE_BROWSER`` is set (CI's
``.ci/run`` installs Chromium and sets it, so CI never skips it silently).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from inpaintenv.benchmark.html import REPORT_FILE
from inpaintenv.cli import main

pytest.importorskip("estimators.classical")

BROWSER = next((p for p in map(shutil.which, ("chromium", "chromium-browser")) if p), None)
if BROWSER is None and os.environ.get("INPAINTENV_REQUIRE_BROWSER"):
    pytest.fail("INPAINTENV_REQUIRE_BROWSER is set but no chromium is on the PATH", pytrace=False)
pytestmark = pytest.mark.skipif(BROWSER is None, reason="no chromium on the PATH (Debian: apt-get install chromium); "
                                                        "CI installs it and runs this test")

#: Installed first in <head>: records page errors and console errors before any other script runs.
HOOK = """<script>
window.__errors = [];
window.addEventListener('error', function (e) { window.__errors.push('error: ' + (e.message || e.target.src)); }, true);
(function () { var orig = console.error; console.error = function () {
  window.__errors.push('console.error: ' + Array.prototype.join.call(arguments, ' ')); orig.apply(console, arguments); }; })();
</script>"""

#: Appended last: checks the images, clicks a header twice, writes the findings into the DOM as JSON.
PROBE = """<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var broken = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); }).map(function (i) { return i.alt; });
  var table = document.getElementById('results-table');
  var heads = Array.prototype.slice.call(table.tHead.rows[0].cells).map(function (h) { return h.textContent; });
  var col = heads.indexOf('task RMSE (m)');
  function column() { return Array.prototype.map.call(table.tBodies[0].rows, function (r) { return r.cells[col].getAttribute('data-v'); }); }
  var before = column();
  table.tHead.rows[0].cells[col].click();
  var ascending = column();
  table.tHead.rows[0].cells[col].click();
  var descending = column();
  table.tHead.rows[0].cells[0].click();
  var names = Array.prototype.map.call(table.tBodies[0].rows, function (r) { return r.cells[0].textContent; });
  var out = document.createElement('pre');
  out.id = 'probe';
  out.textContent = JSON.stringify({images: imgs.length, broken: broken, errors: window.__errors, before: before,
                                    ascending: ascending, descending: descending, names: names});
  document.body.appendChild(out);
});
</script>"""


def _chromium(*args: str, tmp: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [BROWSER, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
         "--hide-scrollbars", f"--user-data-dir={tmp / 'profile'}", "--virtual-time-budget=10000", *args],
        capture_output=True, text=True, timeout=120, check=False)


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("browser") / "run"
    assert main(["benchmark", "-m", "scanline", "-m", "nearest", "-m", "constant", "--synthetic", "--n-frames", "4",
                 "--frame-shape", "48", "160", "--holdout", "0", "--figure-frames", "1", "--quiet",
                 "--out", str(out)]) == 0
    return out


def test_report_in_a_browser_loads_its_images_logs_no_error_and_sorts(run, tmp_path):
    page = (run / REPORT_FILE).read_text()
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("<head>", "<head>" + HOOK, 1).replace("</body>", PROBE + "</body>", 1))
    done = _chromium("--dump-dom", probe.as_uri(), tmp=tmp_path)
    found = re.search(r'<pre id="probe">(.*?)</pre>', done.stdout, re.S)
    assert found, f"the probe did not run; chromium said: {done.stderr[-2000:]}"
    result = json.loads(found.group(1).replace("&quot;", '"').replace("&lt;", "<").replace("&gt;", ">")
                        .replace("&amp;", "&"))
    assert result["images"] >= 5 and result["broken"] == []
    assert result["errors"] == []
    values = [float(v) for v in result["ascending"]]
    assert values == sorted(values) and len(values) == 3
    assert [float(v) for v in result["descending"]] == sorted(values, reverse=True)
    assert result["names"] == sorted(result["names"])  # a text column sorts by its text
    assert not re.search(r"Uncaught|CONSOLE\(\d+\).*[Ee]rror", done.stderr)


def test_report_screenshot_is_not_blank(run, tmp_path):
    import matplotlib.image

    shot = tmp_path / "report.png"
    done = _chromium(f"--screenshot={shot}", "--window-size=1280,1600", (run / REPORT_FILE).as_uri(), tmp=tmp_path)
    assert shot.is_file(), done.stderr[-2000:]
    pixels = matplotlib.image.imread(shot)[..., :3]
    assert pixels.shape[:2] == (1600, 1280)
    not_white = (pixels < 0.95).any(axis=-1)
    assert not_white.mean() > 0.05  # text, table and figures on the page
    assert np.unique((pixels * 255).astype(np.uint8).reshape(-1, 3), axis=0).shape[0] > 200  # figures, in colour
