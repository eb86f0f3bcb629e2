"""The code's structure rules (docs/architecture.md, "Code structure"), read with ``ast``:

- no import cycle between the modules of ``fsi_sph`` (imports inside functions count too);
- no module uses another package's private (underscore) names: ``from x import _name``,
  ``import x._name``, ``module._name``; a package's underscore modules and names are shared
  by the modules of that package only;
- no access to another object's private members (``obj._name`` for an ``obj`` that is not
  ``self`` or ``cls``);
- no file of ``fsi_sph`` over ``MAX_FILE_LINES`` lines, no class over ``MAX_CLASS_LINES``.
"""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "fsi_sph"
MAX_FILE_LINES = 500
MAX_CLASS_LINES = 300
#: files allowed over MAX_FILE_LINES, each with the reason (none: keep it so)
LONG_FILES: dict[str, str] = {}
#: classes allowed over MAX_CLASS_LINES, each with the reason (none: keep it so)
LONG_CLASSES: dict[str, str] = {}


def modules():
    """{dotted name: (path, ast tree)} of every module of the package."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(ROOT).with_suffix("")
        parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
        out[".".join(parts)] = (path, ast.parse(path.read_text(), str(path)))
    return out


def package_of(name, mods):
    """The package a module belongs to (a package's ``__init__`` belongs to itself)."""
    path = mods[name][0]
    return name if path.name == "__init__.py" else name.rpartition(".")[0]


def resolve(node, name, mods):
    """The absolute module named by an ``ImportFrom`` in module ``name``."""
    if node.level == 0:
        return node.module
    base = package_of(name, mods).split(".")
    base = base[:len(base) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


def imports(name, tree, mods):
    """[(module imported, owner of a private name or None, line)] of one module, within
    fsi_sph. The owner of a private name is the package it belongs to: for ``a._b.c`` (or
    ``from a._b import c``) the package ``a``; for ``from a.m import _x`` (``_x`` a name of
    module ``a.m``) the package of ``a.m``."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "fsi_sph":
                    out.append((a.name, private_owner(a.name.split(".")), node.lineno))
        elif isinstance(node, ast.ImportFrom):
            mod = resolve(node, name, mods)
            if mod is None or mod.split(".")[0] != "fsi_sph":
                continue
            for a in node.names:
                sub = f"{mod}.{a.name}"
                target = sub if sub in mods else mod
                owner = private_owner(sub.split("."))
                if owner is not None and sub not in mods and not any(
                        is_private(p) for p in mod.split(".")):
                    owner = package_of(mod, mods) if mod in mods else mod
                out.append((target, owner, node.lineno))
    return out


def private_owner(parts):
    """The package owning the first private segment of a dotted name, or None."""
    for k, p in enumerate(parts):
        if is_private(p):
            return ".".join(parts[:k])
    return None


def is_private(name):
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def test_no_import_cycles():
    mods = modules()
    graph = {name: {m for m, _, _ in imports(name, tree, mods) if m in mods and m != name}
             for name, (_, tree) in mods.items()}
    # Tarjan's strongly connected components: any with more than one module is a cycle
    index, low, stack, on, cycles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert not cycles, f"import cycles: {cycles}"


def test_no_private_imports():
    mods = modules()
    bad = []
    for name, (path, tree) in mods.items():
        for target, owner, line in imports(name, tree, mods):
            if owner is not None and not name.startswith(owner + "."):
                bad.append(f"{path.relative_to(ROOT)}:{line} imports a private name of "
                           f"{owner} ({target})")
    assert not bad, "private names imported from outside their package:\n" + "\n".join(bad)


def test_no_private_member_access():
    """``x._name`` only on ``self``/``cls`` or on a module of the same package."""
    mods = modules()
    bad = []
    for name, (path, tree) in mods.items():
        own = package_of(name, mods)
        same_pkg_aliases = set()  # module aliases that may be reached into (same package)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                mod = resolve(node, name, mods)
                for a in node.names:
                    sub = f"{mod}.{a.name}"
                    if sub in mods and package_of(sub, mods) == own:
                        same_pkg_aliases.add(a.asname or a.name)
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Attribute) and is_private(node.attr)):
                continue
            base = node.value
            if isinstance(base, ast.Name) and base.id in ("self", "cls", *same_pkg_aliases):
                continue
            bad.append(f"{path.relative_to(ROOT)}:{node.lineno} .{node.attr} of "
                       f"{ast.unparse(base)}")
    assert not bad, "private members reached from outside:\n" + "\n".join(bad)


def test_file_and_class_lengths():
    long_files, long_classes = [], []
    for path, tree in modules().values():
        rel = str(path.relative_to(ROOT))
        n = len(path.read_text().splitlines())
        if n > MAX_FILE_LINES and rel not in LONG_FILES:
            long_files.append(f"{rel}: {n} lines")
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef):
                size = node.end_lineno - node.lineno + 1
                if size > MAX_CLASS_LINES and node.name not in LONG_CLASSES:
                    long_classes.append(f"{rel}: class {node.name}: {size} lines")
    assert not long_files, f"files over {MAX_FILE_LINES} lines: {long_files}"
    assert not long_classes, f"classes over {MAX_CLASS_LINES} lines: {long_classes}"


def test_known_long_files_are_still_long():
    """An exception in LONG_FILES is removed once its file is short again."""
    for rel in LONG_FILES:
        path = ROOT / rel
        assert path.exists() and len(path.read_text().splitlines()) > MAX_FILE_LINES, rel
