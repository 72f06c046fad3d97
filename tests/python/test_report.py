"""`python -m viscera report FILE ... --out report.html`: a trainee's attempts on one page that
opens offline, looked at in headless Chromium."""

import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

import matplotlib.image
import numpy as np
import pytest

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def run(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "viscera", *args], capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def attempts(tmp_path_factory):
    """Five attempts at grasp_lift: four scripted (they succeed), one idle for 2 s (it fails)."""
    folder = tmp_path_factory.mktemp("attempts")
    paths = []
    for number, (seed, policy, extra) in enumerate([(1, "scripted", []), (2, "idle", ["--time-limit", "2"]),
                                                    (3, "scripted", []), (4, "scripted", []), (5, "scripted", [])]):
        path = folder / f"attempt{number + 1}.npz"
        done = run("record", "grasp_lift", "--seed", str(seed), "--policy", policy, "--out", str(path), "--quiet",
                   *extra)
        assert done.returncode == 0, done.stderr  # recorded, whatever the verdict
        assert done.stdout.splitlines()[-1].startswith("success: yes" if policy == "scripted" else "success: no")
        paths.append(path)
    return paths


@pytest.fixture(scope="module")
def page(attempts, tmp_path_factory):
    out = tmp_path_factory.mktemp("report") / "report.html"
    done = run("report", *map(str, attempts), "--out", str(out), "--quiet")
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"wrote {out}: 5 attempts of grasp_lift"), done.stdout
    return out


def test_the_page_holds_every_attempt_the_curve_and_the_charts_and_nothing_from_outside(page):
    text = page.read_text()
    rows = re.findall(r'<tr><td>(\d)</td><td class="left">(attempt\d\.npz)</td>', text)
    assert rows == [(str(n), f"attempt{n}.npz") for n in range(1, 6)]
    assert text.count("<h3>Learning curve</h3>") == 1
    assert text.count("<svg") == 1 + 5  # the curve, then one row of charts per attempt
    assert "traction limit 4.62 N" in text and "perforation 10.3 N" in text
    # offline: no script, stylesheet, image or font fetched (the SVGs' xmlns are names, not fetches)
    assert not re.search(r'<(script|link|img|iframe)\b|\bsrc=|url\((?!#)', text)  # url(#id): the SVGs' own clips
    # the failed attempt (2, idle) is not coloured against the band; a succeeded one is
    failed = text[text.index("<td>2</td>"):].split("</tr>")[0]
    assert ">no<" in failed and "background" not in failed
    succeeded = text[text.index("<td>1</td>"):].split("</tr>")[0]
    assert ">yes<" in succeeded and "background:#" in succeeded


@pytest.mark.skipif(CHROMIUM is None, reason="needs Debian's chromium (.ci/run installs it)")
def test_the_page_opens_offline_in_chromium_and_shows_tables_and_charts(page, tmp_path):
    shot = tmp_path / "report.png"
    subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                    "--disable-component-update", "--disable-sync", "--no-first-run",
                    f"--user-data-dir={tempfile.mkdtemp()}", f"--screenshot={shot}", "--window-size=1280,1600",
                    "--virtual-time-budget=3000", page.as_uri()], capture_output=True, timeout=180, check=True)
    image = matplotlib.image.imread(shot)[..., :3]
    assert image.shape[:2] == (1600, 1280)

    def share(rgb) -> float:
        return float((np.abs(image - np.array(rgb) / 255.0).max(axis=2) < 0.03).mean())

    assert share((255, 255, 255)) < 0.9                 # not a blank page
    assert share((0xd8, 0xf0, 0xd8)) > 1e-3            # green cells: figures in the band's best quartile
    assert share((0x1f, 0x77, 0xb4)) > 1e-5             # the charts' first tool, drawn
    assert share((0x2c, 0xa0, 0x2c)) > 1e-5             # the learning curve's succeeded attempts and band line


def test_a_bad_recording_is_one_line_before_anything_replays(attempts, tmp_path):
    broken = tmp_path / "broken.npz"
    broken.write_bytes(pathlib.Path(attempts[0]).read_bytes()[:300])
    out = tmp_path / "r.html"
    done = run("report", str(attempts[0]), str(broken), "--out", str(out))
    assert done.returncode != 0 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert "broken.npz" in done.stderr and not out.exists() and "replaying" not in done.stderr
    done = run("report", str(attempts[0]), "--out", str(tmp_path / "r.pdf"))
    assert done.returncode == 2 and "r.pdf" in done.stderr and len(done.stderr.strip().splitlines()) == 1
