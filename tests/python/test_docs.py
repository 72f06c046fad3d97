"""The documentation: the README stays a front page, and the pages build into a site strictly."""

import re
import subprocess
import sys

import pytest

from test_package import ROOT


def test_the_readme_is_a_front_page_whose_links_resolve():
    """At most 200 lines: what viscera is, the two commands, the pictures, one example, links.
    Every relative link and picture of the README and the pages points at a file of the tree."""
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 200
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", page.read_text()):
            if "://" in target:
                continue
            assert (page.parent / target).exists(), f"{page.relative_to(ROOT)} links to a missing {target}"


def test_the_site_builds_strictly(tmp_path):
    """mkdocs build --strict: no broken link, no page left out of the navigation."""
    pytest.importorskip("mkdocs")  # the [test] extra installs it
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                          cwd=ROOT, capture_output=True, text=True, timeout=300,
                          env={"NO_MKDOCS_2_WARNING": "1", "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stdout + done.stderr
    assert (tmp_path / "site" / "index.html").exists()
    assert (tmp_path / "site" / "config" / "index.html").exists()


def test_the_pages_tables_match_their_results_json():
    """The tables of measured figures (stability map, stiff cases, speed against accuracy, cost per
    substep, the fall, the cavity's speed) are generated from the committed results JSON by
    docs/tables.py: a page edited by hand, or a JSON rerun without regenerating, fails here."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("tables", ROOT / "docs" / "tables.py")
    tables = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tables)
    assert tables.main(["--check"]) == 0
    page = (ROOT / "docs" / "validation.md").read_text()
    assert "<!-- table: stability_map -->" in page and "<!-- table: speed_against_accuracy -->" in page


def _play(task: str, seed: int) -> dict:
    import viscera.tasks
    env = viscera.tasks.load(task, seed=seed)
    policy = viscera.tasks.scripted_policy(env)
    step = env.reset()
    while not step.last():
        step = env.step(policy(step))
    return {"seed": seed, "success": bool(env.task.success(env.physics)),
            "simulated_s": round(float(env.physics.data.time), 2)}


def test_the_pages_episode_figures_are_what_the_code_does():
    """The episodes the pages show and quote (docs/tasks/pictures.json, docs/pixels/episode.json,
    written by task_pictures.py and pixel_pictures.py) end, played again, as their JSON says: a
    change of behaviour that leaves the pictures and figures stale fails here."""
    import json
    shown = json.loads((ROOT / "docs" / "tasks" / "pictures.json").read_text())
    for task, recorded in shown.items():
        assert _play(task, recorded["seed"]) == recorded, task
    episode = json.loads((ROOT / "docs" / "pixels" / "episode.json").read_text())
    same = shown.get(episode["task"], {}).get("seed") == episode["seed"]  # then played above
    played = shown[episode["task"]] if same else _play(episode["task"], episode["seed"])
    assert {k: episode[k] for k in ("seed", "success", "simulated_s")} == played
