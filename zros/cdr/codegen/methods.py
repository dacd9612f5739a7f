"""The generated methods of a message class: ``__init__`` with its checks, defaults, ``__eq__``,
``__repr__``, ``copy``, ``to_dict``, and for uniform structs the rows of their numpy dtype."""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterable

import numpy as np
import numpy.typing as npt

from zros.cdr import convert
from zros.cdr.arrays import Array
from zros.cdr.codegen.ops import STRUCT_CODES, Context, value_dtype
from zros.cdr.codegen.program import Generated, Program
from zros.cdr.errors import FieldError
from zros.cdr.message import Message
from zros.cdr.model import PRIMITIVE_SIZES, Field, FieldType, Kind, MessageDef
from zros.cdr.naming import attribute_name
from zros.cdr.struct_seq import StructSeq, struct_items


def _display_name(name: str) -> str:
    return name.replace('/', '.')


def generate_methods(ctx: Context, msg: MessageDef) -> dict[str, object]:
    """``__init__``, ``__eq__``, ``__repr__``, ``copy`` and ``to_dict`` of a message class.

    For uniform structs also ``_from_tuple`` and ``_to_tuple`` (rows of its numpy dtype).
    """
    result: dict[str, object] = {
        '__init__': _gen_init(ctx, msg),
        '_zros_default': staticmethod(_gen_default(ctx, msg)),
        '__eq__': _gen_eq(ctx, msg),
        '__repr__': _gen_repr(ctx, msg),
        'copy': _gen_copy(ctx, msg),
        'to_dict': _gen_to_dict(ctx, msg),
    }
    if ctx.info(msg.name).uniform:
        result['_from_tuple'] = _gen_from_tuple(ctx, msg)
        result['_to_tuple'] = _gen_to_tuple(ctx, msg)
        rows = _gen_pack_rows(ctx, msg)
        if rows is not None:
            result['_pack_rows'] = rows
    return result


def _field_category(ctx: Context, t: FieldType) -> str:
    """prim, str, nested, prim_array, str_list, nested_list, struct_seq."""
    if t.kind is Kind.SCALAR:
        return 'prim' if t.is_primitive else 'str' if t.is_string else 'nested'
    if t.is_primitive:
        return 'prim_array'
    if t.is_string:
        return 'str_list'
    if t.kind is not Kind.ARRAY and ctx.info(t.base).uniform:
        return 'struct_seq'
    return 'nested_list'


def _scalar_check(t: FieldType, attr: str, type_: str, src: Program) -> str:
    """The cheap test a correct scalar argument passes; the slow path explains or converts."""
    if t.base in ('float32', 'float64'):
        return f'{type_}({attr}) is not {src.ref(float, "float")}'
    if t.base == 'bool':
        return f'{type_}({attr}) is not {src.ref(bool, "bool")}'
    if t.is_string:
        check = f'{type_}({attr}) is not {src.ref(str, "str")}'
        return check + (f' or len({attr}) > {t.string_bound}' if t.string_bound else '')
    # no range test here: it costs more than the type test, and encoding checks ranges
    return f'{type_}({attr}) is not {src.ref(int, "int")}'


def _default_expr(ctx: Context, src: Program, f: Field, category: str) -> str:
    """The expression of a field's default value (a fresh object for mutable ones)."""
    t = f.type
    if category in ('prim', 'str'):
        default = f.default
        if default is None:
            zero = 0.0 if t.base.startswith('float') else False if t.base == 'bool' else 0
            default = '' if t.is_string else zero
        return repr(default) if isinstance(default, (bool, int)) else src.ref(default, 'd')
    if category == 'prim_array':
        dtype = src.ref(value_dtype(t.base), 'D')
        if f.default is not None:
            return f'{src.ref(np.array, "array")}({src.ref(f.default, "d")}, {dtype})'
        if t.kind is Kind.ARRAY:
            return f'{src.ref(np.zeros, "zeros")}({t.length}, {dtype})'
        return src.ref(convert.empty_array(value_dtype(t.base)), 'E')
    if category == 'str_list':
        if f.default is not None:
            return f'{src.ref(list, "list")}({src.ref(f.default, "d")})'
        return f"[''] * {t.length}" if t.kind is Kind.ARRAY else '[]'
    cls = src.ref(ctx.cls(t.base), 'C')
    if category == 'nested':
        return f'{cls}._zros_default()'
    if category == 'nested_list':
        if t.kind is Kind.ARRAY:
            return f'[{cls}._zros_default() for _ in {src.ref(range, "range")}({t.length})]'
        return '[]'
    return f'{src.ref(StructSeq, "Seq")}({cls})'


def _gen_default(ctx: Context, msg: MessageDef) -> Callable[[], Message]:
    """A message with every default value, made without the constructor's checks (nested
    defaults use it: they need no checking, and ``Msg()`` of a nested type costs twice as much)."""
    src = Program()
    src.add(f'o = {src.blank(ctx.cls(msg.name))}()')
    for f in msg.fields:
        value = _default_expr(ctx, src, f, _field_category(ctx, f.type))
        src.add(f'o.{attribute_name(f.name)} = {value}')
    src.add('return o')
    return src.compile('', '_zros_default')


def _gen_init(ctx: Context, msg: MessageDef) -> Generated:
    # parameters are field names, which may shadow builtins: generated code uses only _names.
    # Each scalar argument passes one cheap test (its exact type); anything else goes to a
    # convert helper that converts it (an int for a float...) or raises a FieldError.
    src = Program()
    missing = src.ref(_MISSING, 'MISSING')
    type_ = src.ref(type, 'type')
    name = src.ref(msg.name, 'name')
    fields = tuple(attribute_name(f.name) for f in msg.fields)
    src.add(f'if _extra: raise {src.ref(_unknown_field, "unknown")}({name}, {fields!r}, _extra)')
    params: list[str] = []
    for f in msg.fields:
        t = f.type
        attr = attribute_name(f.name)
        category = _field_category(ctx, t)
        target = f'_self.{attr}'
        where = src.ref((msg.name, attr), 'w')
        default = _default_expr(ctx, src, f, category)
        if category in ('prim', 'str'):
            params.append(f'{attr}={default}')
            scalar = src.ref(convert.scalar, 'scalar')
            src.add(
                f'if {_scalar_check(t, attr, type_, src)}: '
                f'{attr} = {scalar}({attr}, {t.base!r}, {t.string_bound}, {where})'
            )
            src.add(f'{target} = {attr}')
            continue
        params.append(f'{attr}={missing}')
        shape = (
            t.length if t.kind is Kind.ARRAY else -1,
            t.length if t.kind is Kind.BOUNDED else -1,
        )
        if category == 'prim_array':
            dtype = src.ref(value_dtype(t.base), 'D')
            conv = src.ref(convert.init_array, 'conv')
            value = f'{conv}({attr}, {dtype}, {shape}, {where})'
        elif category == 'str_list':
            strings = src.ref(convert.string_list, 'strings')
            value = f'{strings}({attr}, {t.base!r}, {t.string_bound}, {shape}, {where})'
        else:
            cls = src.ref(ctx.cls(t.base), 'C')
            if category == 'nested':
                nested = src.ref(convert.message, 'message')
                value = (
                    f'({attr} if {type_}({attr}) is {cls} else {nested}({cls}, {attr}, {where}))'
                )
            elif category == 'nested_list':
                value = (
                    f'{src.ref(convert.message_list, "messages")}({cls}, {attr}, {shape}, {where})'
                )
            else:
                items = src.ref(struct_items, 'items')
                seq = src.ref(StructSeq, 'Seq')
                value = f'{seq}({cls}, {items}({cls}, {attr}, {shape[1]}, {where}))'
        src.add(f'{target} = {default} if {attr} is {missing} else {value}')
    signature = ', '.join(['_self', *params, '**_extra'])
    init = src.compile(signature, '__init__')
    init.__qualname__ = f'{msg.name.rsplit("/", 1)[1]}.__init__'
    return init


def _unknown_field(type_name: str, fields: tuple[str, ...], extra: dict[str, object]) -> Exception:
    return FieldError.unknown(type_name, next(iter(extra)), fields)


_MISSING = object()


def _gen_eq(ctx: Context, msg: MessageDef) -> Callable[[Message, object], bool]:
    src = Program()
    # the same type from another registry (e.g. a bag's own definitions) compares by content
    src.add(
        'if other.__class__ is not self.__class__ and (getattr(other, "__msgtype__", None) '
        '!= self.__msgtype__ or other._fields != self._fields): return NotImplemented'
    )
    checks = []
    equal = src.ref(_array_equal, 'aeq')
    for f in msg.fields:
        attr = attribute_name(f.name)
        if _field_category(ctx, f.type) == 'prim_array':
            checks.append(f'{equal}(self.{attr}, other.{attr})')
        else:
            checks.append(f'self.{attr} == other.{attr}')
    src.add(f'return {" and ".join(checks) or "True"}')
    return src.compile('self, other', '__eq__')


def _array_equal(a: npt.ArrayLike, b: npt.ArrayLike) -> bool:
    return bool(np.array_equal(a, b))


def _gen_repr(ctx: Context, msg: MessageDef) -> Callable[[Message], str]:
    src = Program()
    parts = ', '.join(
        f'{attribute_name(f.name)}={{self.{attribute_name(f.name)}!r}}' for f in msg.fields
    )
    src.add(f'return f{_display_name(msg.name) + "(" + parts + ")"!r}')
    return src.compile('self', '__repr__')


def _gen_copy(ctx: Context, msg: MessageDef) -> Callable[[Message], Message]:
    src = Program()
    src.add(f'o = {src.blank(ctx.cls(msg.name))}()')
    array = src.ref(np.array, 'array')
    for f in msg.fields:
        attr = attribute_name(f.name)
        category = _field_category(ctx, f.type)
        if category in ('prim', 'str'):
            src.add(f'o.{attr} = self.{attr}')
        elif category == 'prim_array':
            src.add(f'o.{attr} = {array}(self.{attr})')
        elif category == 'str_list':
            src.add(f'o.{attr} = list(self.{attr})')
        elif category in ('nested', 'struct_seq'):
            src.add(f'o.{attr} = self.{attr}.copy()')
        else:
            src.add(f'o.{attr} = [x.copy() for x in self.{attr}]')
    src.add('return o')
    return src.compile('self', 'copy')


def _to_list(value: Array | Iterable[object]) -> list[object]:
    items: list[object] = value.tolist() if isinstance(value, np.ndarray) else list(value)
    return items


def _gen_to_dict(ctx: Context, msg: MessageDef) -> Callable[[Message], dict[str, object]]:
    src = Program()
    to_list = src.ref(_to_list, 'tolist')
    items = []
    for f in msg.fields:
        attr = attribute_name(f.name)
        category = _field_category(ctx, f.type)
        if category in ('prim', 'str'):
            value = f'self.{attr}'
        elif category == 'prim_array':
            value = f'{to_list}(self.{attr})'
        elif category == 'str_list':
            value = f'list(self.{attr})'
        elif category == 'nested':
            value = f'self.{attr}.to_dict()'
        else:
            value = f'[x.to_dict() for x in self.{attr}]'
        items.append(f'{f.name!r}: {value}')
    src.add('return {' + ', '.join(items) + '}')
    return src.compile('self', 'to_dict')


def _tuple_pattern(ctx: Context, msg: MessageDef, src: Program, var: str, lines: list[str]) -> str:
    """Unpacking pattern of one dtype row; appends to ``lines`` the code building ``var``."""
    lines.append(f'{var} = {src.blank(ctx.cls(msg.name))}()')
    names = []
    for f in msg.fields:
        attr = attribute_name(f.name)
        t = f.type
        if t.is_primitive:
            name = src.tmp('x')
            names.append(name)
            if t.kind is Kind.ARRAY:
                dtype = src.ref(value_dtype(t.base), 'D')
                lines.append(f'{var}.{attr} = {src.ref(np.array, "array")}({name}, {dtype})')
            else:
                lines.append(f'{var}.{attr} = {name}')
        elif t.kind is Kind.ARRAY:
            name = src.tmp('x')
            names.append(name)
            sub_lines: list[str] = []
            element = src.tmp('y')
            pattern = _tuple_pattern(ctx, ctx.resolve(t.base), src, element, sub_lines)
            helper = src.tmp('row')
            lines.append(f'{var}.{attr} = [{helper}(r) for r in {name}]')
            sub_source = Program()
            sub_source.objects = src.objects
            sub_source.add(f'{pattern} = r')
            for line in sub_lines:
                sub_source.add(line)
            sub_source.add(f'return {element}')
            src.objects[helper] = sub_source.compile('r', 'row')
        else:
            sub = src.tmp('v')
            names.append(_tuple_pattern(ctx, ctx.resolve(t.base), src, sub, lines))
            lines.append(f'{var}.{attr} = {sub}')
    return '(' + ''.join(n + ', ' for n in names) + ')'


def _gen_from_tuple(ctx: Context, msg: MessageDef) -> Callable[[tuple[object, ...]], Message]:
    src = Program()
    lines: list[str] = []
    pattern = _tuple_pattern(ctx, msg, src, 'o', lines)
    if msg.fields:
        src.add(f'{pattern} = t')
    for line in lines:
        src.add(line)
    src.add('return o')
    return src.compile('t', '_from_tuple')


def _tuple_expr(ctx: Context, msg: MessageDef, var: str) -> str:
    items = []
    for f in msg.fields:
        attr = f'{var}.{attribute_name(f.name)}'
        t = f.type
        if t.is_primitive:
            items.append(attr)
        elif t.kind is Kind.ARRAY:
            items.append(f'[{_tuple_expr(ctx, ctx.resolve(t.base), "y")} for y in {attr}]')
        else:
            items.append(_tuple_expr(ctx, ctx.resolve(t.base), attr))
    return '(' + ''.join(item + ', ' for item in items) + ')'


def _gen_to_tuple(ctx: Context, msg: MessageDef) -> Callable[[Message], tuple[object, ...]]:
    src = Program()
    src.add(f'return {_tuple_expr(ctx, msg, "o")}')
    return src.compile('o', '_to_tuple')


def _row_layout(
    ctx: Context, msg: MessageDef, var: str, offset: int, out: list[tuple[int, str, str]]
) -> int | None:
    """Append (offset, struct code, value expression) for each scalar of one row; None if the
    struct holds a fixed array (such rows are packed through numpy instead)."""
    if not msg.fields:
        out.append((offset, 'x', ''))
        return offset + 1
    for f in msg.fields:
        t = f.type
        if t.kind is not Kind.SCALAR:
            return None
        expr = f'{var}.{attribute_name(f.name)}'
        if t.is_primitive:
            size = PRIMITIVE_SIZES[t.base]
            offset += -offset % size
            out.append((offset, STRUCT_CODES[t.base], expr))
            offset += size
        else:
            info = ctx.info(t.base)
            offset += -offset % info.first_align
            end = _row_layout(ctx, ctx.resolve(t.base), expr, offset, out)
            if end is None:
                return None
            offset = end
    return offset


def _gen_pack_rows(ctx: Context, msg: MessageDef) -> Callable[[list[Message]], bytes] | None:
    """``_pack_rows(items) -> bytes``: rows of a uniform struct, one ``struct`` call each."""
    layout: list[tuple[int, str, str]] = []
    if _row_layout(ctx, msg, 'o', 0, layout) is None:
        return None
    fmt = ['<']
    position = 0
    values = []
    for offset, code, expr in layout:
        if offset > position:
            fmt.append(f'{offset - position}x')
        fmt.append(code)
        if code != 'x':
            values.append(expr)
        position = offset + (1 if code in 'x?bB' else struct.calcsize('<' + code))
    size = ctx.info(msg.name).size
    if size > position:
        fmt.append(f'{size - position}x')
    src = Program()
    pack = src.ref(struct.Struct(''.join(fmt)).pack, 'pack')
    join = src.ref(b''.join, 'join')
    src.add(f'return {join}([{pack}({", ".join(values)}) for o in items])')
    return src.compile('items', '_pack_rows')
