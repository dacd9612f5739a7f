"""Write definitions back as .msg/.srv/.action text, alone or bundled with their dependencies."""

from __future__ import annotations

from typing import TYPE_CHECKING

from zros.cdr.model import ActionDef, DefaultValue, Definition, FieldType, MessageDef, ServiceDef

if TYPE_CHECKING:
    from zros.cdr.registry import TypeRegistry

_RULE = '=' * 80


def _value(value: DefaultValue) -> str:
    if isinstance(value, tuple):
        return '[' + ', '.join(_value(item) for item in value) + ']'
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, str):
        return '"' + value.replace('"', '\\"') + '"'
    return repr(value)


def _type_text(ftype: FieldType, package: str) -> str:
    """The type as a .msg file in ``package`` writes it (``pkg/Name`` for other packages)."""
    text = str(ftype)
    if ftype.is_nested:
        pkg, _, short = ftype.base.split('/')
        text = text.replace(ftype.base, short if pkg == package else f'{pkg}/{short}', 1)
    return text


def render_message(msg: MessageDef) -> str:
    """The .msg text of a message: constants first, then fields with their defaults."""
    package = msg.name.split('/')[0]
    lines = [
        f'{c.type} {c.name}={c.value if isinstance(c.value, str) else _value(c.value)}'
        for c in msg.constants
    ]
    for f in msg.fields:
        line = f'{_type_text(f.type, package)} {f.name}'
        if f.default is not None:
            line += ' ' + _value(f.default)
        lines.append(line)
    return '\n'.join(lines) + ('\n' if lines else '')


def render_definition(definition: Definition) -> str:
    """The text of a message, service (``---`` between parts) or action."""
    if isinstance(definition, MessageDef):
        return render_message(definition)
    parts: list[MessageDef]
    if isinstance(definition, ServiceDef):
        parts = [definition.request, definition.response]
    else:
        assert isinstance(definition, ActionDef)
        parts = [definition.goal, definition.result, definition.feedback]
    return '---\n'.join(render_message(part) for part in parts)


def render_bundle(registry: TypeRegistry, name: str) -> str:
    """A message with every type it depends on appended, the format bags embed (``ros2msg``)."""
    main = registry.message_definition(name)
    seen: list[str] = []
    queue = main.nested_types()
    while queue:
        nested = queue.pop(0)
        if nested not in seen:
            seen.append(nested)
            queue.extend(registry.message_definition(nested).nested_types())
    chunks = [render_message(main)]
    for nested in seen:
        pkg, _, short = nested.split('/')
        chunks.append(
            f'{_RULE}\nMSG: {pkg}/{short}\n' + render_message(registry.message_definition(nested))
        )
    return ''.join(chunks)
