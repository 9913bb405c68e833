"""Check the hard edges of the package's design over its syntax trees (no imports are run).

    python scripts/check_architecture.py [ROOT]

- no import cycles between the package's modules (imports inside functions count);
- each layer imports only its own and lower layers (``LAYERS``: physics, identify and control,
  envs, agents, report, train and olympics, cli; the root's helper modules below all);
- no import of another module's private names, and no private attribute read off anything but
  ``self`` or ``cls``;
- no module over ``MAX_MODULE`` lines, and no function that takes more than ``MAX_PARAMETERS``
  parameters by position (``self``, ``cls`` and keyword-only ones aside: pass an object, or name
  the options); compiled kernels (``@jitable``, or a ``def`` marked ``# kernel``) take arrays by
  position and are exempt;
- ``physics``, ``identify`` and ``control`` import no simulator (MuJoCo);
- nothing in the repository cites files outside it or speaks of a tracker's tickets.

Prints one line per violation and exits 1 if there is any.
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

PACKAGE = "acrobot_mj"
MAX_MODULE, MAX_PARAMETERS, MAX_FUNCTION = 500, 6, 60
#: Rank of each subpackage: a module may import modules of its own rank or lower.
LAYERS = {
    "physics": 1,
    "identify": 2,
    "control": 2,
    "envs": 3,
    "agents": 4,
    "report": 5,
    "train": 6,
    "olympics": 6,
    "cli": 7,
}
#: Modules at the package's top: helpers below every layer, and the root above all.
HELPERS, ROOT_RANK = 0, 8
NO_SIMULATOR = ("physics", "identify", "control")
#: Documented public functions whose names start with an underscore.
PUBLIC_UNDERSCORED = {"os._exit"}
SIMULATORS = ("mujoco",)
#: Text that points outside the repository (its own docs/explain/design.md is fine), or at a tracker
#: (the words are assembled so that this file does not match itself).
OUTSIDE = re.compile(r"\bDESIGN\.md|\.\./shared\b|\bshared/DESIGN")
TRACKER = re.compile(r"\b" + "iss" + r"ues?\b|\btick" + r"ets?\b", re.IGNORECASE)
TEXT_SUFFIXES = (".py", ".md", ".toml", ".xml", ".txt", ".cfg", ".yml", ".yaml")


def module_name(root: Path, path: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def rank(module: str) -> int:
    parts = module.split(".")
    if len(parts) == 1 or parts[1] == "__main__":  # the package, and `python -m acrobot_mj`
        return ROOT_RANK
    return LAYERS.get(parts[1], HELPERS)


def resolve(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    """The absolute module a ``from ... import`` names."""
    if node.level == 0:
        return node.module or ""
    base = module.split(".")
    if not is_package:
        base = base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imports(tree: ast.AST, module: str, is_package: bool, modules: set[str]):
    """(imported module, line, private names) for every import in the tree."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno, []
        elif isinstance(node, ast.ImportFrom):
            target = resolve(module, is_package, node)
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                private = [alias.name] if _private(alias.name) else []
                yield (sub if sub in modules else target), node.lineno, private


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def function_sizes(tree: ast.AST, lines: list[str]):
    """(name, line, parameters, lines) of every function but compiled kernels. Parameters count
    positional and keyword-only ones (``self``, ``cls``, ``*args`` and ``**kwargs`` aside); a
    constructor's keyword-only settings with defaults (as Gymnasium envs take theirs) aside."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            kernel = "# kernel" in lines[node.lineno - 1] or any(
                ast.unparse(d) == "jitable" for d in node.decorator_list
            )
            positional = [a.arg for a in node.args.posonlyargs + node.args.args]
            count = len([name for name in positional if name not in ("self", "cls")])
            if node.name != "__init__":
                count += len(node.args.kwonlyargs)
            first = min([node.lineno, *(d.lineno for d in node.decorator_list)])
            if not kernel:
                yield node.name, node.lineno, count, (node.end_lineno or first) - first + 1


def private_reads(tree: ast.AST):
    """(line, text) of private attributes read off something other than self or cls."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _private(node.attr):
            owner = node.value
            text = f"{ast.unparse(owner)}.{node.attr}"
            if not (isinstance(owner, ast.Name) and owner.id in ("self", "cls")):
                if text not in PUBLIC_UNDERSCORED:
                    yield node.lineno, text


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1 or v in graph.get(v, ()):
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def check_package(root: Path) -> list[str]:
    files = sorted((root / PACKAGE).rglob("*.py"))
    names = {module_name(root, f): f for f in files}
    modules = set(names)
    graph: dict[str, set[str]] = {m: set() for m in modules}
    problems = []
    for module, path in names.items():
        text = path.read_text()
        where = path.relative_to(root)
        tree = ast.parse(text)
        lines = text.count("\n") + (not text.endswith("\n"))
        if lines > MAX_MODULE:
            problems.append(f"{where}: {lines} lines (at most {MAX_MODULE})")
        for name, line, count, length in function_sizes(tree, text.splitlines()):
            if count > MAX_PARAMETERS:
                problems.append(
                    f"{where}:{line}: {name}() takes {count} parameters (at most "
                    f"{MAX_PARAMETERS}: pass an object that owns them)"
                )
            if length > MAX_FUNCTION:
                problems.append(
                    f"{where}:{line}: {name}() is {length} lines (at most {MAX_FUNCTION})"
                )
        for line, text_ in private_reads(tree):
            problems.append(f"{where}:{line}: reads the private attribute {text_}")
        is_package = path.name == "__init__.py"
        for target, line, private in imports(tree, module, is_package, modules):
            top = target.split(".")[0]
            layer = module.split(".")[1] if "." in module else ""
            if top in SIMULATORS and layer in NO_SIMULATOR:
                problems.append(f"{where}:{line}: {module} imports the simulator {target}")
            if top != PACKAGE:
                continue
            if private:
                problems.append(f"{where}:{line}: imports private names {private} of {target}")
            if any(_private(part) for part in target.split(".")):
                problems.append(f"{where}:{line}: imports the private module {target}")
            if target not in modules or target == module:
                continue
            graph[module].add(target)
            if rank(target) > rank(module):
                problems.append(
                    f"{where}:{line}: {module} (layer {rank(module)}) imports {target} "
                    f"(layer {rank(target)}): imports go down the layers only"
                )
    for component in cycles(graph):
        problems.append("import cycle: " + " -> ".join(component))
    return problems


def check_text(root: Path) -> list[str]:
    """Citations of files outside the repository, or of a tracker."""
    problems = []
    this = Path(__file__).resolve()
    skip = {".git", ".venv", "runs", "node_modules", "build", "dist"}
    for path in sorted(root.rglob("*")):
        parts = set(path.relative_to(root).parts)
        if path.suffix not in TEXT_SUFFIXES or parts & skip or not path.is_file():
            continue
        if path.resolve() == this or any(p.endswith(".egg-info") for p in parts):
            continue
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            match = OUTSIDE.search(line) or TRACKER.search(line)
            if match:
                problems.append(
                    f"{path.relative_to(root)}:{number}: cites {match.group(0)!r} "
                    "(the repository must stand on its own)"
                )
    return problems


def main(argv: list[str]) -> int:
    root = Path(argv[1] if len(argv) > 1 else Path(__file__).resolve().parents[1])
    problems = check_package(root) + check_text(root)
    for problem in problems:
        print(problem)
    print(f"{len(problems)} problems" if problems else "architecture: all hard edges hold")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
