"""The hand-written stubs (silpose/__init__.pyi, silpose/dask.pyi) name exactly what the modules
hold: every public function and class, and every public attribute of every class."""

import ast
import inspect
import os

import silpose
import silpose.dask

PACKAGE = os.path.dirname(silpose.__file__)


def stub_names(path):
    tree = ast.parse(open(path).read())
    names = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            members = set()
            for item in node.body:
                if isinstance(item, ast.FunctionDef):
                    members.add(item.name)
                elif isinstance(item, ast.AnnAssign):
                    members.add(item.target.id)
            names[node.name] = members
        elif isinstance(node, ast.FunctionDef):
            names[node.name] = None
    return names


def public(name):
    return not name.startswith("_")


def class_members(cls):
    members = set()
    for name, _ in inspect.getmembers(cls):
        if public(name) or name in ("__init__", "__iter__", "__next__", "__enter__", "__exit__"):
            # pybind11 gives a class without constructor an __init__ slot that raises.
            if name == "__init__" and type(cls.__dict__.get("__init__")).__name__ in (
                    "NoneType", "wrapper_descriptor"):
                continue
            if name in ("__iter__", "__next__", "__enter__", "__exit__") and name not in cls.__dict__:
                continue
            members.add(name)
    return members


def check(module, path, expected_names):
    stubs = stub_names(path)
    assert set(stubs) == set(expected_names), path
    for name, members in stubs.items():
        value = getattr(module, name)
        if members is None:
            assert callable(value) and not inspect.isclass(value), name
            continue
        assert inspect.isclass(value), name
        if issubclass(value, Exception):
            continue
        assert members == class_members(value), name


def test_package_stub_matches_the_module():
    exported = set(silpose.__all__)
    assert exported == {n for n in dir(silpose._silpose) if public(n)} | {"track_video"}
    check(silpose, os.path.join(PACKAGE, "__init__.pyi"), exported)


def test_dask_stub_matches_the_module():
    check(silpose.dask, os.path.join(PACKAGE, "dask.pyi"), set(silpose.dask.__all__))


def test_everything_has_a_docstring():
    for name in silpose.__all__:
        value = getattr(silpose, name)
        assert (value.__doc__ or "").strip(), name
        if inspect.isclass(value) and not issubclass(value, Exception):
            for member in class_members(value):
                attribute = getattr(value, member)
                assert (attribute.__doc__ or "").strip(), f"{name}.{member}"
    for name in silpose.dask.__all__:
        assert getattr(silpose.dask, name).__doc__.strip()
