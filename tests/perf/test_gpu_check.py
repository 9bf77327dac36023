"""perf/gpu_check.py: ``--quick`` on the CPU prints every section and the JSON keys of a GPU run.

Its first section (``pytest -m gpu tests/gpu`` in a subprocess) is checked here without
running pytest inside pytest: the quick run leaves it out, and the section's own logic (the
command, the forced-CPU variable, the JUnit counts, the time-out) is tested with a stand-in
for the subprocess. The tests marked ``gpu`` themselves run in the main suite (on the CPU
without a CUDA device).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
TRAIN_KEYS = {"batch", "precision", "frame", "workers", "flop_per_step", "steps", "step_ms", "samples_per_s",
              "data_wait_share", "model_tflops", "final_loss", "bf16_peak_share", "peak_gpu_memory_bytes"}


@pytest.fixture(scope="module")
def gc(load_benchmark):
    return load_benchmark("gpu_check")


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """stdout and the JSON file of one ``--quick`` run, with ``$OUT`` set and no ``--out``."""
    out = tmp_path_factory.mktemp("out")
    env = {**os.environ, "OUT": str(out)}
    env.pop("INPAINTENV_GPU_TESTS_ON_CPU", None)  # the check itself must set it for its tests
    done = subprocess.run([sys.executable, "perf/gpu_check.py", "--quick", "--skip-tests"], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return done.stdout, json.loads((out / "gpu_check.json").read_text())


def _positive(value) -> bool:
    return isinstance(value, (int, float)) and math.isfinite(value) and value > 0


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_quick_run_prints_every_section(quick_run):
    stdout, _ = quick_run
    lines = stdout.splitlines()
    for header in ("## 1. tests marked gpu", "## 2. training throughput: study-unet-tv network and loss, 32x96",
                   "## 3. predict throughput", "## 4. summary"):
        assert any(line.startswith(header) for line in lines), header
    assert any(line.startswith("device: cpu") and "torch " in line and "CUDA none" in line for line in lines)
    assert "bf16 dense peak: peak unknown" in lines
    assert "tests: not run (skipped: --skip-tests)" in lines
    for precision, workers in (("fp32", 1), ("bf16", 1), ("bf16", 0)):
        (row,) = [line for line in lines if line.startswith(f"train batch=2 {precision} workers={workers}: ")]
        for part in ("samples/s", "data wait", "TFLOP/s", "GFLOP/step; peak unknown", "peak GPU memory n/a (cpu)"):
            assert part in row, (part, row)
    for model in ("pretrained", "study-unet-tv"):
        assert any(line.startswith(f"predict {model} cpu: ") and "frames/s" in line for line in lines)
        assert f"predict {model} cuda: not measured (no CUDA device)" in lines
    assert not any(line.startswith("SKIPPED") for line in lines)
    # The machine-readable line is the file $OUT/gpu_check.json holds.
    (json_line,) = [line for line in lines if line.startswith("JSON ")]
    assert json.loads(json_line.removeprefix("JSON ")) == quick_run[1]


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_quick_run_json_has_the_keys_of_a_gpu_run(quick_run, load_benchmark):
    _, summary = quick_run
    assert summary["mode"] == "quick" and summary["bf16_peak_tflops"] is None
    assert {"device", "device_name", "torch", "cuda", "cudnn"} <= set(summary["environment"])
    assert summary["environment"]["cuda"] == "none"
    assert summary["sections"] == {"tests": "skipped: --skip-tests", "training": "ran", "predict": "ran"}
    assert summary["tests"] == {}
    # The counted FLOPs are the architecture's (perf/scaling_training.py's formula): the
    # backward costs two forwards less the first convolution's input gradient (batch 2, 1 channel).
    flops = 3 * load_benchmark("_unet_flops").unet_conv_flops(16, 4, 32, 96, batch=2) - 2 * 18 * 16 * 32 * 96
    # Each batch in fp32 and bf16 with the loader's workers, then bf16 without workers (fit's default).
    assert [(r["batch"], r["precision"], r["workers"]) for r in summary["training"]] == [
        (2, "fp32", 1), (2, "bf16", 1), (2, "bf16", 0)]
    for row in summary["training"]:
        assert TRAIN_KEYS <= set(row) and "error" not in row
        assert row["flop_per_step"] == flops
        for key in ("samples_per_s", "step_ms", "model_tflops", "steps"):
            assert _positive(row[key]), (key, row)
        assert 0 <= row["data_wait_share"] < 1 and math.isfinite(row["final_loss"])
        assert row["bf16_peak_share"] is None and row["peak_gpu_memory_bytes"] is None  # CPU: no peak, no GPU
    rows = {(r["model"], r["device"]): r for r in summary["predict"]}
    assert set(rows) == {(m, d) for m in ("pretrained", "study-unet-tv") for d in ("cpu", "cuda")}
    for model in ("pretrained", "study-unet-tv"):
        assert _positive(rows[model, "cpu"]["frames_per_s"]) and rows[model, "cpu"]["finite"]
        assert rows[model, "cuda"]["skipped"] == "no CUDA device"
    assert 0 < summary["elapsed_s"] < summary["max_seconds"]


def test_bf16_peaks_by_device_name(gc):
    assert gc.bf16_peak_tflops("NVIDIA H200") == 989.0
    assert gc.bf16_peak_tflops("NVIDIA H100 80GB HBM3") == 989.0
    assert gc.bf16_peak_tflops("NVIDIA H100 PCIe") == 756.0
    assert gc.bf16_peak_tflops("NVIDIA A100-SXM4-80GB") == 312.0
    assert gc.bf16_peak_tflops("Tesla T4") is None
    assert gc.bf16_peak_tflops("NVIDIA RTX A1000") is None  # not an A100


def test_max_seconds_skips_with_a_line_and_keeps_the_keys(gc, capsys):
    summary = gc.main(["--quick", "--max-seconds", "0.001", "--skip-tests"])
    out = capsys.readouterr().out
    assert "SKIPPED training batch=2 fp32 workers=1:" in out and "SKIPPED predict:" in out
    assert "train batch=2 bf16 workers=0: not measured (--max-seconds)" in out
    assert summary["sections"] == {"tests": "skipped: --skip-tests", "training": "skipped", "predict": "skipped"}
    assert [r["skipped"] for r in summary["training"]] == ["--max-seconds"] * 3
    assert out.splitlines()[-1].startswith("JSON ")


def test_training_rows(gc):
    assert gc.training_rows([4, 16, 64], 8) == [(4, False, 8), (4, True, 8), (16, False, 8), (16, True, 8),
                                                (64, False, 8), (64, True, 8), (16, True, 0)]
    assert gc.training_rows([2], 0) == [(2, False, 0), (2, True, 0)]  # no second row without workers


def test_junit_counts(load_benchmark, tmp_path):
    xml = tmp_path / "r.xml"
    xml.write_text(
        '<testsuites><testsuite name="pytest">'
        '<testcase classname="a" name="ok"/><testcase classname="a" name="ok2"/>'
        '<testcase classname="a" name="bad"><failure message="x"/></testcase>'
        '<testcase classname="a" name="broken"><error message="y"/></testcase>'
        '<testcase classname="a" name="later"><skipped message="z"/></testcase>'
        "</testsuite></testsuites>"
    )
    assert load_benchmark("_gpu_check_machine")._junit_counts(xml) == {
        "passed": 2, "failed": 1, "errors": 1, "skipped": 1, "failures": ["a::bad", "a::broken"]}


@pytest.mark.parametrize("argv", [["--steps", "0"], ["--batches", "0"], ["--warmup", "0"], ["--max-seconds", "0"]])
def test_bad_arguments_are_refused(gc, argv):
    with pytest.raises(SystemExit):
        gc.main(argv)


class _FakePytest:
    """Stands in for ``subprocess.run`` of the first section: records the call, writes a JUnit XML."""

    def __init__(self, returncode: int = 0, timeout: bool = False):
        self.returncode, self.timeout, self.calls = returncode, timeout, []

    def __call__(self, cmd, cwd, env, capture_output, text, timeout):
        self.calls.append((cmd, env, timeout))
        if self.timeout:
            raise subprocess.TimeoutExpired(cmd, timeout)
        xml = next(a for a in cmd if a.startswith("--junitxml=")).removeprefix("--junitxml=")
        Path(xml).write_text('<testsuite><testcase classname="g" name="ok"/>'
                             '<testcase classname="g" name="bad"><failure message="x"/></testcase></testsuite>')
        return subprocess.CompletedProcess(cmd, self.returncode, "out", "err")


@pytest.mark.parametrize("force_cpu", [True, False])
def test_gpu_tests_section_runs_the_gpu_tests_and_reads_their_counts(load_benchmark, monkeypatch, force_cpu):
    machine = load_benchmark("_gpu_check_machine")
    fake = _FakePytest(returncode=1)
    monkeypatch.setattr(machine.subprocess, "run", fake)
    monkeypatch.delenv("INPAINTENV_GPU_TESTS_ON_CPU", raising=False)
    counts = machine.run_gpu_tests(force_cpu=force_cpu, timeout=42.0)
    ((cmd, env, timeout),) = fake.calls
    assert cmd[1:7] == ["-m", "pytest", "-m", "gpu", "tests/gpu", "-q"] and timeout == 42.0
    assert (env.get("INPAINTENV_GPU_TESTS_ON_CPU") == "1") is force_cpu
    assert str(machine.REPO) in env["PYTHONPATH"].split(os.pathsep)
    assert (counts["passed"], counts["failed"], counts["failures"]) == (1, 1, ["g::bad"])
    assert counts["error"] == "pytest exited 1" and counts["output_tail"] == "outerr"


def test_gpu_tests_section_reports_a_time_out(load_benchmark, monkeypatch):
    machine = load_benchmark("_gpu_check_machine")
    monkeypatch.setattr(machine.subprocess, "run", _FakePytest(timeout=True))
    counts = machine.run_gpu_tests(force_cpu=True, timeout=5.0)
    assert counts["error"] == "timed out after 5 s" and counts["passed"] == 0 and counts["returncode"] is None
