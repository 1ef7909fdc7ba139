"""The type stubs (kestrel/_kestrel.pyi) name what the module defines, no more, no less."""

import ast
import pathlib

import kestrel
from kestrel import _kestrel


def stub_tree():
    path = pathlib.Path(_kestrel.__file__).with_name("_kestrel.pyi")
    return ast.parse(path.read_text())


def test_stubs_match_the_module():
    stubbed = {}
    for node in stub_tree().body:
        if isinstance(node, ast.ClassDef):
            stubbed[node.name] = {n.name for n in node.body if isinstance(n, ast.FunctionDef)}
        elif isinstance(node, ast.FunctionDef):
            stubbed[node.name] = set()
    public = {name for name in dir(_kestrel) if not name.startswith("_")}
    assert public == set(stubbed), "stub and module differ"
    for name, members in stubbed.items():
        obj = getattr(_kestrel, name)
        missing = {m for m in members if not hasattr(obj, m)}
        assert not missing, f"{name}: stubbed but not defined: {missing}"
        if isinstance(obj, type) and name != "InputError":
            defined = {m for m in vars(obj) if not m.startswith("_")}
            assert defined <= members, f"{name}: defined but not stubbed: {defined - members}"
    assert set(kestrel.__all__) == public


def test_everything_has_a_docstring():
    undocumented = []
    for name in kestrel.__all__:
        obj = getattr(kestrel, name)
        if not (obj.__doc__ or "").strip():
            undocumented.append(name)
        if isinstance(obj, type) and not issubclass(obj, Exception):
            for member, value in vars(obj).items():
                if member.startswith("_"):
                    continue
                doc = getattr(value, "__doc__", None) or ""
                if not doc.strip():
                    undocumented.append(f"{name}.{member}")
    assert not undocumented, undocumented
