"""Runs the C core's own tests (ctest): the core builds and passes without MuJoCo."""

import pathlib
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.mark.skipif(shutil.which("cmake") is None or shutil.which("ctest") is None, reason="needs cmake")
def test_core_ctest(tmp_path):
    build = tmp_path / "core"
    def run(*command):
        result = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
        assert result.returncode == 0, f"{' '.join(command)}\n{result.stdout}\n{result.stderr}"
        return result.stdout
    run("cmake", "-S", str(ROOT), "-B", str(build), "-DVISCERA_BUILD_PLUGIN=OFF", "-DCMAKE_BUILD_TYPE=Release")
    run("cmake", "--build", str(build), "--parallel", "2")
    output = run("ctest", "--test-dir", str(build), "--output-on-failure")
    assert "100% tests passed" in output, output
