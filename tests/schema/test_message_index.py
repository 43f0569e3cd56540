"""`bus_schema.messages` is the bus contract's index: every type its area modules define is
listed there, once, and is the same object."""

import ast
import importlib
import pkgutil
from pathlib import Path

import msgspec

from bus_schema import TOPICS, messages


def _defined_names(module) -> list[str]:
    """Public names a module defines itself (classes and assignments, not imports)."""
    tree = ast.parse(Path(module.__file__).read_text())
    names = []
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            names.append(node.name)
        elif isinstance(node, ast.Assign):
            names += [t.id for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.append(node.target.id)
    return [n for n in names if not n.startswith("_")]


def test_the_index_lists_every_public_name_defined_in_an_area_module():
    areas = [importlib.import_module(f"{messages.__name__}.{info.name}")
             for info in pkgutil.iter_modules(messages.__path__)]
    assert len(areas) >= 7
    for module in areas:
        for name in _defined_names(module):
            assert name in messages.__all__, f"bus_schema.messages.__all__ misses {module.__name__}.{name}"
            assert getattr(messages, name) is getattr(module, name), name
    assert len(messages.__all__) == len(set(messages.__all__))
    assert all(hasattr(messages, name) for name in messages.__all__)


def test_every_topic_type_is_a_struct_of_the_index():
    for topic in TOPICS:
        assert issubclass(topic.type, msgspec.Struct)
        assert getattr(messages, topic.type.__name__) is topic.type
