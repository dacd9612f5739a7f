"""Every public function and class of zros has a docstring (the API reference is made of them).

Public means: the names in ``__all__`` of ``zros`` and of each module that has one, else the
names without a leading underscore that the module defines, in every module whose dotted path
has no part starting with ``_``. Of the classes of the modules the API reference shows
(``DOCUMENTED``), public methods and properties need one too. ``zros.cli`` is the ``zros``
command, documented by its ``--help`` (generated into the CLI reference), not as Python API.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from types import ModuleType

import pytest

import zros

#: modules whose classes' members the API reference renders (docs/api/*.md)
DOCUMENTED = {
    'zros',
    'zros.api',
    'zros.node',
    'zros.node.facade',
    'zros.node.factories',
    'zros.node.graph_methods',
    'zros.node.parameter_methods',
    'zros.pubsub',
    'zros.pubsub.publisher',
    'zros.pubsub.subscriber',
    'zros.pubsub.taps',
    'zros.qos',
    'zros.services',
    'zros.services.server',
    'zros.services.client',
    'zros.services.errors',
    'zros.actions.server',
    'zros.actions.server_goal',
    'zros.actions.client',
    'zros.actions.common',
    'zros.params',
    'zros.params.client',
    'zros.params.descriptor',
    'zros.params.store',
    'zros.params.values',
    'zros.runtime.clock',
    'zros.runtime.entity',
    'zros.runtime.timers',
    'zros.runtime.logger',
    'zros.graph',
    'zros.graph.view',
    'zros.wire.bridge_wire',
    'zros.transport',
    'zros.transport.config',
    'zros.transport.router',
    'zros.transport.session',
    'zros.transport.pki',
    'zros.cdr',
    'zros.bag',
    'zros.testing',
}


def public_modules() -> list[str]:
    names = ['zros']
    for info in pkgutil.walk_packages(zros.__path__, 'zros.'):
        parts = info.name.split('.')
        if any(part.startswith('_') for part in parts) or parts[1] == 'cli':
            continue
        names.append(info.name)
    return sorted(names)


MODULES = public_modules()


def public_names(module: ModuleType) -> list[str]:
    exported = getattr(module, '__all__', None)
    if exported is not None:
        return list(exported)
    return [
        name
        for name, value in vars(module).items()
        if not name.startswith('_') and getattr(value, '__module__', None) == module.__name__
    ]


def own_docstring(obj: object) -> str | None:
    """The docstring written for ``obj`` itself (a class's is never inherited)."""
    if inspect.isclass(obj):
        doc = obj.__dict__.get('__doc__')
        return doc if isinstance(doc, str) else None
    return getattr(obj, '__doc__', None)


def members_without_docstrings(cls: type) -> list[str]:
    missing = []
    for name, value in vars(cls).items():
        if name.startswith('_'):
            continue
        if isinstance(value, property):
            target = value.fget
        elif isinstance(value, (staticmethod, classmethod)):
            target = value.__func__
        elif inspect.isfunction(value):
            target = value
        else:
            continue
        if target is not None and not (target.__doc__ or '').strip():
            missing.append(f'{cls.__module__}.{cls.__qualname__}.{name}')
    return missing


@pytest.mark.parametrize('module_name', MODULES)
def test_public_functions_and_classes_have_docstrings(module_name: str) -> None:
    module = importlib.import_module(module_name)
    assert (module.__doc__ or '').strip(), f'module {module_name} has no docstring'
    missing = []
    for name in public_names(module):
        obj = getattr(module, name)
        if not (inspect.isclass(obj) or inspect.isfunction(obj)):
            continue
        if not str(getattr(obj, '__module__', '')).startswith('zros'):
            continue  # re-exported from another library
        if not (own_docstring(obj) or '').strip():
            missing.append(f'{obj.__module__}.{obj.__qualname__}')
        if inspect.isclass(obj) and module_name in DOCUMENTED:
            missing += members_without_docstrings(obj)
    assert not missing, 'add docstrings to:\n  ' + '\n  '.join(sorted(set(missing)))


def test_the_modules_are_found() -> None:
    assert {'zros', 'zros.node', 'zros.pubsub', 'zros.cdr', 'zros.transport'} <= set(MODULES)
    assert not [name for name in MODULES if name.startswith('zros.cli')]


def test_a_missing_docstring_is_noticed() -> None:
    class Documented:
        """Here."""

        def method(self) -> None:
            pass

        @property
        def value(self) -> int:
            return 1

    assert own_docstring(Documented) == 'Here.'
    assert sorted(members_without_docstrings(Documented)) == [
        f'{__name__}.{Documented.__qualname__}.method',
        f'{__name__}.{Documented.__qualname__}.value',
    ]
