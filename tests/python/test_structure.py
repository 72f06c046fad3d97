"""The code's structure, as docs/layout.md states it: data flows one way down.

- In plugin/, no file includes, or calls into, a file that includes or calls back into it
  (a cycle between files, at any length): the core's stages sit in layers.
- Every core source file has its own header beside it (src/x.c, src/x.h), Box2D's layout,
  and includes it first.
- Each stage of the step owns its state: a struct its own header declares, carved from the
  rod's allocation; only four sources reach into the rod's stages to hand each its own, and
  every other source takes another stage's state read-only.
- In python/viscera, no module imports a module that imports it back (at any length,
  imports inside functions included).
"""

from __future__ import annotations

import ast
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[2]
PLUGIN = ROOT / "plugin"
PACKAGE = ROOT / "python" / "viscera"

# a function definition at the start of a line: return type, name, parameters
DEFINITION = re.compile(r"^(?:static\s+|inline\s+|VSC_VECTOR_CLONES\s+|VSC_EXPORT\s+)*[A-Za-z_][\w\s\*]*?\b(\w+)\(",
                        re.M)
INCLUDE = re.compile(r'^#include "([^"]+)"', re.M)
COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one node (Tarjan)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for other in graph.get(node, ()):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in on_stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                other = stack.pop()
                on_stack.discard(other)
                component.append(other)
                if other == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in list(graph):
        if node not in index:
            visit(node)
    return found


def _sources() -> dict[str, str]:
    files = sorted(PLUGIN.rglob("*.c")) + sorted(PLUGIN.rglob("*.h"))
    return {str(f.relative_to(PLUGIN)): COMMENT.sub("", f.read_text()) for f in files}


def _resolve(including: str, name: str, sources: dict[str, str]) -> str | None:
    here = pathlib.PurePosixPath(including).parent
    for candidate in (str(here / name), f"core/include/{name}", f"core/src/{name}"):
        if candidate in sources:
            return candidate
    return None


def c_include_graph() -> dict[str, set[str]]:
    sources = _sources()
    return {path: {r for r in (_resolve(path, name, sources) for name in INCLUDE.findall(text)) if r}
            for path, text in sources.items()}


def c_call_graph() -> dict[str, set[str]]:
    """File to files whose functions it calls (.c files; a definition's own file excluded)."""
    sources = {p: t for p, t in _sources().items() if p.endswith(".c")}
    defined = {}
    for path, text in sources.items():
        for name in DEFINITION.findall(text):
            defined.setdefault(name, path)
    graph = {}
    for path, text in sources.items():
        called = set(re.findall(r"\b(\w+)\s*\(", text))
        graph[path] = {defined[name] for name in called if name in defined and defined[name] != path}
    return graph


def python_import_graph() -> dict[str, set[str]]:
    modules = {}
    for f in PACKAGE.rglob("*.py"):
        parts = list(f.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        modules[".".join(parts)] = f
    graph = {}
    for name, f in modules.items():
        package = name if f.name == "__init__.py" else name.rsplit(".", 1)[0]
        targets = set()
        for node in ast.walk(ast.parse(f.read_text())):
            # an import of a.b.c runs a, a.b and a.b.c; the edge is the deepest module named (a
            # package's __init__ running for its submodules is no cycle). `from a import x`
            # reads a itself unless x is a submodule.
            if isinstance(node, ast.Import):
                targets.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")
                    anchor = anchor[:len(anchor) - (node.level - 1)]
                    base = ".".join(anchor + ([base] if base else []))
                for alias in node.names:
                    targets.add(f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base)
        graph[name] = {t for t in targets if t in modules and t != name}
    return graph


def test_no_include_cycle_in_the_plugin():
    assert _cycles(c_include_graph()) == []


def test_no_call_cycle_between_the_plugins_files():
    graph = c_call_graph()
    assert len(graph) > 20  # the reader found the files
    assert "core/src/vsc_place.c" in graph["core/src/vsc_forces.c"]  # ... and the calls
    assert _cycles(graph) == []


def test_every_core_source_has_its_own_header_and_includes_it_first():
    """Each core source includes its own header first: its private one (src/), where it declares
    something the public one does not, else its public one (include/viscera/). A private header
    that would only include the public one is not written (the review found 13 such)."""
    for source in sorted((PLUGIN / "core" / "src").glob("*.c")):
        private, public = source.with_suffix(".h"), PLUGIN / "core" / "include" / "viscera" / f"{source.stem}.h"
        assert private.exists() or public.exists(), f"{source.name} has no header"
        own = private.name if private.exists() else f"viscera/{public.name}"
        first = INCLUDE.search(COMMENT.sub("", source.read_text()))
        assert first and first.group(1) == own, f"{source.name} includes {first.group(1)} first, not {own}"
    for header in sorted((PLUGIN / "core" / "src").glob("*.h")):
        code = [line for line in COMMENT.sub("", header.read_text()).splitlines()
                if line.strip() and not line.startswith(("#ifndef", "#define", "#endif"))]
        assert not (len(code) == 1 and code[0].startswith('#include "viscera/')), f"{header.name} holds nothing"


# each stage's state: its struct and the core sources (stems) that own it, header included
# (the energy queries keep an elastic scratch of their own, in the step's backup)
STAGE_STATES = {"vsc_placement": {"vsc_place"}, "vsc_elastic_scratch": {"vsc_elastic", "vsc_energy"},
                "vsc_contact_lists": {"vsc_contact_lists"}, "vsc_contact_pass": {"vsc_contact"},
                "vsc_touch_records": {"vsc_touch", "vsc_contact"}, "vsc_contact_load": {"vsc_contact_load", "vsc_contact"},
                "vsc_sleep_flags": {"vsc_sleep"}, "vsc_scheme_scratch": {"vsc_schemes"},
                "vsc_step_backup": {"vsc_step"}}
# the sources that hand each stage its own: the rod's creation and public queries, the
# evaluation, the step, the schemes
STAGE_HANDLERS = {"vsc_rod.c", "vsc_forces.c", "vsc_step.c", "vsc_schemes.c"}


def test_each_stage_owns_its_state():
    src = PLUGIN / "core" / "src"
    sources = {f.name: COMMENT.sub("", f.read_text()) for f in sorted(src.glob("*.[ch]"))}
    reaching = {name for name, text in sources.items() if re.search(r"\bstages\s*(\.|->)", text)}
    assert reaching == STAGE_HANDLERS, f"sources reaching into the rod's stages: {sorted(reaching)}"
    assert "work" not in re.findall(r"\w+", sources["vsc_rod.h"])  # no shared work struct left
    for state, owners in STAGE_STATES.items():
        declared = [name for name, text in sources.items() if re.search(rf"\bstruct {state}\s*\{{", text)]
        assert len(declared) == 1 and declared[0][:-2] in owners, f"{state} declared in {declared}"
        for name, text in sources.items():
            if name in STAGE_HANDLERS or name == "vsc_rod.h" or name[:-2] in owners:
                continue
            for match in re.finditer(rf"(\bconst\s+)?\b{state}\s*\*", text):  # another stage's state: read only
                assert match.group(1), f"{name} takes {state} writable: {match.group(0)}"


def test_no_import_cycle_in_the_package():
    graph = python_import_graph()
    assert "viscera.tasks" in graph and "viscera.intestine" in graph
    assert _cycles(graph) == []
