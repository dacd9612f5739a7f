"""``zros interface``: list types and show their definitions."""

from __future__ import annotations

import argparse

from zros.cdr import default_registry
from zros.cdr.model import MessageDef
from zros.cdr.render import render_bundle, render_definition


def show(args: argparse.Namespace) -> int:
    """Print the definition of a type (with its dependencies with --all, its hash with --hash)."""
    registry = default_registry()
    definition = registry.definition(args.type)
    if args.all and isinstance(definition, MessageDef):
        print(render_bundle(registry, definition.name), end='')
    else:
        print(render_definition(definition), end='')
    if args.hash:
        from zros.cdr.hashing import type_hash

        print(f'# {type_hash(registry, definition.name)}')
    return 0


def list_types(args: argparse.Namespace) -> int:
    """Print every type name zros can resolve, one per line."""
    for name in default_registry().names():
        if args.pattern in name:
            print(name)
    return 0
