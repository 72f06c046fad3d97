"""Every Python snippet of the README and docs/ runs on its own, copied as is, from the clone's root.

A snippet that cannot run here (a cluster, a display) says so in an HTML comment on the line
before its fence, `<!-- snippet: not run ... -->`; it is still compiled, so it stays valid Python.
"""

import os
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
FENCE = re.compile(r"^(?:(<!-- snippet: not run[^>]*-->)\n)?```python\n(.*?)^```", re.M | re.S)


def snippets():
    for page in PAGES:
        text = page.read_text()
        for match in FENCE.finditer(text):
            line = text.count("\n", 0, match.start(2)) + 1
            yield pytest.param(match.group(2), match.group(1), id=f"{page.relative_to(ROOT)}:{line}")


def test_pages_have_snippets():
    assert len(list(snippets())) >= 8  # the README's and docs/scaling.md's: the regex still finds them


@pytest.mark.parametrize("code, not_run", list(snippets()))
def test_snippet_runs_alone(code, not_run, tmp_path):
    compile(code, "<snippet>", "exec")
    if not_run:
        pytest.skip(not_run)
    # a fresh interpreter in the clone's root, as a reader pastes it; files it writes go to tmp
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                            timeout=600, env={**os.environ, "TMPDIR": str(tmp_path)})
    assert result.returncode == 0, f"{result.stdout[-2000:]}\n{result.stderr[-4000:]}"
    assert "Traceback" not in result.stderr


def test_readme_names_every_system_package_ci_installs():
    """A user on a fresh Debian machine learns from the README what CI installs with apt."""
    ci = (ROOT / ".ci" / "run").read_text()
    packages = re.search(r'^packages="([^"]+)"', ci, re.M).group(1).split()
    readme_apt = " ".join(re.findall(r"apt-get install ([^\n#]+)", (ROOT / "README.md").read_text())).split()
    missing = [p for p in packages if p not in readme_apt and p != "ninja-build"]  # pip brings ninja itself
    assert missing == [], f"README's apt-get lines lack {missing}"
