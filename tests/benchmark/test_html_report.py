"""report.html of a run folder: every task's figures (a scan-only run included), the sortable table,
the rebuild by ``inpaintenv report`` from the folder alone, the size budget."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from inpaintenv.benchmark import figures
from inpaintenv.files import ownership
from inpaintenv.benchmark.html import REPORT_FILE, build_html
from inpaintenv.cli import main

pytest.importorskip("estimators.classical")

SMALL = ["--synthetic", "--n-frames", "4", "--frame-shape", "48", "160", "--holdout", "0", "--figure-frames", "1",
         "--quiet"]


@pytest.fixture(scope="module")
def every_task(tmp_path_factory) -> Path:
    """The classical suite (15 methods) on its three tasks: holes in maps, densify scans, holes in scans."""
    out = tmp_path_factory.mktemp("html") / "run"
    assert main(["benchmark", "--suite", "classical", *SMALL, "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def scan_only(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("html") / "scan"
    assert main(["benchmark", "-m", "scanline", "-m", "nearest", "--input", "scan", "-p", "densify-v1", *SMALL,
                 "--out", str(out)]) == 0
    return out


def _sections(page: str) -> dict[str, str]:
    """The page's task sections by their id (``task-<task>``), each up to the next section."""
    parts = re.split(r"<h2 id='", page)
    return {p.split("'", 1)[0]: p for p in parts[1:]}


def _embedded(section: str) -> list[str]:
    """The ``alt`` of every embedded PNG of a section."""
    return re.findall(r'<img alt="([^"]*)" src="data:image/png;base64,[A-Za-z0-9+/=]{100,}">', section)


@pytest.mark.parametrize("task, folder, by_size", [
    ("rect-v1", "figures", True),
    ("scan_densify-v1", "figures/scan_densify-v1", False),  # no hole: no hole-size figure
    ("scan_rect-v1", "figures/scan_rect-v1", True),
])
def test_every_task_holds_its_figures(every_task, task, folder, by_size):
    page = (every_task / REPORT_FILE).read_text()
    section = _sections(page)[f"task-{task}"]
    shown = _embedded(section)
    expected = {f"{folder}/error_vs_distance.png", f"{folder}/error_vs_nearest.png", f"{folder}/frame_0000.png"}
    expected |= {f"{folder}/error_vs_hole_size.png"} if by_size else set()
    assert expected <= set(shown)
    assert any(alt.startswith("per-frame RMSE of ") for alt in shown)  # drawn from the rows
    assert not by_size or (every_task / folder / "error_vs_hole_size.png").is_file()
    assert by_size or not (every_task / folder / "error_vs_hole_size.png").exists()


def test_a_scan_only_run_gets_figures(scan_only):
    section = _sections((scan_only / REPORT_FILE).read_text())["task-scan_densify-v1"]
    assert {"figures/error_vs_distance.png", "figures/error_vs_nearest.png", "figures/frame_0000.png"} <= set(
        _embedded(section))


def test_results_table_has_every_method_and_task_and_the_ratio(every_task):
    page = (every_task / REPORT_FILE).read_text()
    table = page[page.index('<table class="sortable"'):page.index("</table>")]
    body = table[table.index("<tbody>"):]
    rows = body.count("<tr")
    assert rows == 15 + 5 + 5  # the suite on maps, its five scan methods on each scan task
    assert "÷ strongest classical [95 % CI]" in table
    assert 'data-v="1.0"' in body  # the strongest classical method of a task is 1.000 of itself
    # Every number cell has its sort key; the page loads nothing from elsewhere.
    assert not re.search(r"(src|href)=[\"'](https?:)?//", page)


def test_report_command_rebuilds_the_same_page_from_the_folder(every_task, tmp_path, capsys):
    copy = tmp_path / "run"
    shutil.copytree(every_task, copy)
    before = (copy / REPORT_FILE).read_bytes()
    (copy / REPORT_FILE).unlink()
    assert main(["report", str(copy)]) == 0
    assert (copy / REPORT_FILE).read_bytes() == before
    assert capsys.readouterr().out.strip() == str(copy / REPORT_FILE)


def test_rerun_of_a_finished_run_rewrites_the_page(scan_only, tmp_path):
    copy = tmp_path / "run"
    shutil.copytree(scan_only, copy)
    (copy / REPORT_FILE).unlink()
    assert main(["benchmark", "-m", "scanline", "-m", "nearest", "--input", "scan", "-p", "densify-v1", *SMALL,
                 "--out", str(copy)]) == 0
    page = (copy / REPORT_FILE).read_text()
    assert str(copy) in page  # this command, in the provenance
    assert _embedded(_sections(page)["task-scan_densify-v1"]) == _embedded(
        _sections((scan_only / REPORT_FILE).read_text())["task-scan_densify-v1"])


def test_a_figure_another_part_of_the_run_draws_is_picked_up_in_its_task(every_task, tmp_path):
    copy = tmp_path / "run"
    shutil.copytree(every_task, copy)
    plt = figures._pyplot()
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.plot([0, 1], [1, 0])
    figures._save(fig, copy / "figures" / "scan_rect-v1" / "sparsification.png", dpi=60)  # claimed as the run's
    section = _sections(build_html(copy))["task-scan_rect-v1"]
    assert "figures/scan_rect-v1/sparsification.png" in _embedded(section)
    assert "Sparsification." in section


def test_report_of_a_folder_without_rows_is_one_error(tmp_path, capsys):
    assert main(["report", str(tmp_path)]) == 1
    assert "holds no rows" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []  # nothing written there


def test_report_stays_small(every_task):
    # 15 methods x 3 tasks, a panel per task: far under the 5 MB a 10-method, 3-task run may take.
    size = (every_task / REPORT_FILE).stat().st_size
    assert size < 2_000_000, size
    assert ownership.owns(every_task, REPORT_FILE)


def test_report_of_ten_methods_on_three_tasks_stays_under_5_mb(tmp_path, monkeypatch):
    # Frames of KITTI's aspect, the default figure frames (2 panels per task, the 8 spread frames).
    from inpaintenv.benchmark import suites

    ten = suites.SUITES["classical"][:10]
    monkeypatch.setitem(suites.SUITES, "classical", ten)
    out = tmp_path / "run"
    assert main(["benchmark", "--suite", "classical", "--synthetic", "--n-frames", "8", "--frame-shape", "64", "212",
                 "--holdout", "0", "--quiet", "--out", str(out)]) == 0
    page = (out / REPORT_FILE).read_text()
    assert all(name in page for name in ten)
    sections = _sections(page)
    assert all(len(_embedded(sections[f"task-{t}"])) >= 4 for t in ("rect-v1", "scan_densify-v1", "scan_rect-v1"))
    size = (out / REPORT_FILE).stat().st_size
    assert size < 5_000_000, size
