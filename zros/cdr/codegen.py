"""Generate Python source for the codec and methods of one message class.

A message is flattened into a list of operations in wire order: fixed-size reads or writes,
variable-size bodies (strings, sequences) and loops. Consecutive fixed-size operations, across
nested structs, merge into one ``struct`` call whenever their alignment is known statically; the
code tracks the body offset modulo 8 for that. Nested types are inlined, so decoding a message is
one function call.

Two flavours exist: the fast one, which raises the internal ``Bad`` (or any exception) on bad
input, and the *traced* one, which does one field at a time and turns any failure into a
:class:`~zros.cdr.errors.CdrError` naming the field and offset. The fast codec runs first; the
traced one only runs to explain a failure.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Protocol, Union

import numpy as np

from zros.cdr import convert
from zros.cdr.layout import StructInfo, numpy_dtype
from zros.cdr.model import INTEGER_RANGES, PRIMITIVE_SIZES, FieldType, Kind, MessageDef
from zros.cdr.naming import attribute_name

STRUCT_CODES = {
    'bool': '?',
    'byte': 'B',
    'char': 'B',
    'int8': 'b',
    'uint8': 'B',
    'int16': 'h',
    'uint16': 'H',
    'int32': 'i',
    'uint32': 'I',
    'int64': 'q',
    'uint64': 'Q',
    'float32': 'f',
    'float64': 'd',
}

HEADER_LE = b'\x00\x01\x00\x00'


class Context(Protocol):
    """What the generator needs to know about other types."""

    def resolve(self, name: str) -> MessageDef: ...

    def info(self, name: str) -> StructInfo: ...

    def cls(self, name: str) -> type: ...

    def dtype(self, name: str, endian: str) -> np.dtype: ...


# --- operations ---------------------------------------------------------------------------


@dataclass
class _Fix:
    """A fixed-size scalar: decode stores into ``ref``; encode writes the expression ``ref``."""

    code: str
    size: int
    ref: str | None
    path: str
    primitive: str = ''


@dataclass
class _FixArr:
    primitive: str
    count: int
    ref: str
    path: str


@dataclass
class _Pre:
    """Statements with no wire effect, emitted at once (object creation, hoisting, checks)."""

    lines: list[str]


@dataclass
class _Str:
    ref: str
    count: str
    bound: int
    path: str
    wide: bool


@dataclass
class _Seq:
    """A primitive sequence (``element`` is a primitive) or a uniform struct sequence."""

    element: str
    ref: str
    count: str
    bound: int
    path: str
    struct: bool


@dataclass
class _Loop:
    count: str
    bound: int
    min_size: int
    ref: str
    item: str
    index: str
    body: list[_Op]
    path: str


_Op = Union[_Fix, _FixArr, _Pre, _Str, _Seq, _Loop, '_Blob']


@dataclass(frozen=True)
class _State:
    """The body offset is known to be ``mod`` modulo ``modulus``."""

    mod: int
    modulus: int

    def advance(self, size: int) -> _State:
        return _State((self.mod + size) % self.modulus, self.modulus)

    def static_pad(self, align: int) -> int | None:
        if align == 1:
            return 0
        if self.modulus >= align:
            return -self.mod % align
        return None


_UNKNOWN = _State(0, 1)
_START = _State(0, 8)


def _merge_state(a: _State, b: _State) -> _State:
    modulus = min(a.modulus, b.modulus)
    while modulus > 1 and a.mod % modulus != b.mod % modulus:
        modulus //= 2
    return _State(a.mod % modulus, modulus)


class _Source:
    """Python source under construction plus the objects it refers to."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.depth = 1
        self.objects: dict[str, Any] = {}
        self._ids: dict[int, str] = {}
        self._counter = 0

    def add(self, line: str) -> None:
        self.lines.append('    ' * self.depth + line)

    @contextmanager
    def block(self, header: str) -> Iterator[None]:
        self.add(header)
        self.depth += 1
        yield
        self.depth -= 1

    def tmp(self, prefix: str) -> str:
        self._counter += 1
        return f'{prefix}{self._counter}'

    def ref(self, obj: Any, hint: str) -> str:
        """A name in the generated code that refers to ``obj``."""
        key = id(obj)
        if key not in self._ids:
            name = f'_{hint}{len(self._ids)}'
            self._ids[key] = name
            self.objects[name] = obj
        return self._ids[key]

    def compile(self, signature: str, name: str) -> Callable[..., Any]:
        params = ', '.join(self.objects)
        text = f'def _factory({params}):\n    def {name}({signature}):\n'
        text += '\n'.join('    ' + line for line in self.lines)
        text += f'\n    return {name}\n'
        scope: dict[str, Any] = {}
        exec(compile(text, f'<zros codec {name}>', 'exec'), scope)
        function: Callable[..., Any] = scope['_factory'](**self.objects)
        function.__zros_source__ = text  # type: ignore[attr-defined]
        return function


def _path_literal(path: str) -> str:
    return 'f' + repr(path) if '{' in path else repr(path)


def _dynamic_align(align: int) -> str:
    if align == 8:
        return 'pos += (4 - pos) & 7'
    if align == 4:
        return 'pos += -pos & 3'
    return 'pos += pos & 1'


# --- decoding -----------------------------------------------------------------------------


class _DecoderBuilder:
    def __init__(self, ctx: Context, endian: str, text_from_memoryview: bool, trace: bool) -> None:
        self.ctx = ctx
        self.endian = endian
        self.mv = text_from_memoryview
        self.trace = trace
        self.src = _Source()
        self.bad = self.src.ref(convert.Bad, 'Bad')
        self.new = self.src.ref(object.__new__, 'new')
        self.frombuffer = self.src.ref(np.frombuffer, 'fb')

    # ops

    def struct_ops(self, msg: MessageDef, var: str, path: str, ops: list[_Op]) -> None:
        if not msg.fields:
            ops.append(_Fix('x', 1, None, path or '(empty message)'))
            return
        for f in msg.fields:
            ref = f'{var}.{attribute_name(f.name)}'
            fpath = f'{path}.{f.name}' if path else f.name
            t = f.type
            if t.kind is Kind.SCALAR:
                self.scalar_ops(t, ref, fpath, ops)
            elif t.kind is Kind.ARRAY:
                if t.is_primitive:
                    ops.append(_FixArr(t.base, t.length, ref, fpath))
                else:
                    ops.append(self.loop(t, str(t.length), -1, ref, fpath))
            else:
                count = self.src.tmp('n')
                ops.append(_Fix('I', 4, count, fpath))
                bound = t.length if t.kind is Kind.BOUNDED else -1
                if t.is_primitive:
                    ops.append(_Seq(t.base, ref, count, bound, fpath, False))
                elif t.is_nested and self.ctx.info(t.base).uniform:
                    ops.append(_Seq(t.base, ref, count, bound, fpath, True))
                else:
                    ops.append(self.loop(t, count, bound, ref, fpath))

    def scalar_ops(self, t: FieldType, ref: str, path: str, ops: list[_Op]) -> None:
        if t.is_primitive:
            ops.append(_Fix(STRUCT_CODES[t.base], PRIMITIVE_SIZES[t.base], ref, path, t.base))
        elif t.is_string:
            count = self.src.tmp('n')
            ops.append(_Fix('I', 4, count, path))
            ops.append(_Str(ref, count, t.string_bound, path, t.base == 'wstring'))
        else:
            var = self.src.tmp('v')
            cls = self.src.ref(self.ctx.cls(t.base), 'C')
            ops.append(_Pre([f'{var} = {self.new}({cls})', f'{ref} = {var}']))
            self.struct_ops(self.ctx.resolve(t.base), var, path, ops)

    def loop(self, t: FieldType, count: str, bound: int, ref: str, path: str) -> _Loop:
        index = self.src.tmp('i')
        item = self.src.tmp('e')
        body: list[_Op] = []
        self.scalar_ops(t.element, item, f'{path}[{{{index}}}]', body)
        min_size = 4 if t.is_string else self.ctx.info(t.base).min_size
        return _Loop(count, bound, min_size, ref, item, index, body, path)

    # emission

    def align(self, state: _State, align: int) -> _State:
        pad = state.static_pad(align)
        if pad is None:
            self.src.add(_dynamic_align(align))
            return _State(0, align)
        if pad:
            self.src.add(f'pos += {pad}')
        return state.advance(pad)

    def mark(self, path: str) -> None:
        if self.trace:
            self.src.add(f'_f = {_path_literal(path)}; _p = pos')

    def emit(self, ops: list[_Op], state: _State) -> _State:
        run: list[tuple[int, _Fix | _FixArr]] = []
        run_state = state
        offset = 0
        for op in ops:
            if isinstance(op, _Pre):
                for line in op.lines:
                    self.src.add(line)
                continue
            if isinstance(op, (_Fix, _FixArr)) and not self.trace:
                size = PRIMITIVE_SIZES[op.primitive] if isinstance(op, _FixArr) else op.size
                align = 1 if isinstance(op, _Fix) and op.code == 'x' else size
                if run and run_state.modulus >= align:
                    offset += -(run_state.mod + offset) % align
                else:
                    if run:
                        state = self.flush(run, run_state, offset)
                        run = []
                    pad = state.static_pad(align)
                    if pad is None:
                        self.src.add(_dynamic_align(align))
                        state = _State(0, align)
                        pad = 0
                    run_state = state
                    offset = pad
                run.append((offset, op))
                offset += size * (op.count if isinstance(op, _FixArr) else 1)
                continue
            if run:
                state = self.flush(run, run_state, offset)
                run = []
            state = self.emit_one(op, state)
        if run:
            state = self.flush(run, run_state, offset)
        return state

    def flush(self, run: list[tuple[int, _Fix | _FixArr]], state: _State, total: int) -> _State:
        fmt = [self.endian]
        targets: list[str] = []
        arrays: list[tuple[int, _FixArr]] = []
        position = 0
        for offset, op in run:
            if offset > position:
                fmt.append(f'{offset - position}x')
            if isinstance(op, _FixArr):
                size = PRIMITIVE_SIZES[op.primitive] * op.count
                fmt.append(f'{size}x')
                arrays.append((offset, op))
                position = offset + size
            else:
                fmt.append(op.code)
                if op.ref is not None:
                    targets.append(op.ref)
                position = offset + op.size
        if total > position:
            fmt.append(f'{total - position}x')
        packer = self.src.ref(struct.Struct(''.join(fmt)), 'S')
        if targets:
            self.src.add(f'{", ".join(targets)}, = {packer}.unpack_from(buf, pos)')
        else:
            self.src.add(f'{packer}.unpack_from(buf, pos)')
        for offset, array in arrays:
            where = f'pos + {offset}'
            self.src.add(
                f'{array.ref} = {self.array_expr(array.primitive, str(array.count), where)}'
            )
        self.src.add(f'pos += {total}')
        return state.advance(total)

    def array_expr(self, primitive: str, count: str, where: str) -> str:
        dtype = self.src.ref(numpy_dtype(primitive, self.endian), 'D')
        expr = f'{self.frombuffer}(buf, {dtype}, {count}, {where})'
        return f'({expr} != 0)' if primitive == 'bool' else expr

    def fail(self, condition: str, message: str) -> None:
        if self.trace:
            self.src.add(f'if {condition}: raise {self.bad}(f{message!r})')
        else:
            self.src.add(f'if {condition}: raise {self.bad}')

    def emit_one(self, op: _Op, state: _State) -> _State:
        src = self.src
        if isinstance(op, _Fix):
            align = 1 if op.code in 'x?' else op.size
            state = self.align(state, align)
            self.mark(op.path)
            packer = src.ref(struct.Struct(self.endian + op.code), 'S')
            if op.ref is None:
                src.add(f'{packer}.unpack_from(buf, pos)')
            else:
                src.add(f'{op.ref}, = {packer}.unpack_from(buf, pos)')
            src.add(f'pos += {op.size}')
            return state.advance(op.size)
        if isinstance(op, _FixArr):
            size = PRIMITIVE_SIZES[op.primitive]
            state = self.align(state, size)
            self.mark(op.path)
            self.fail(
                f'pos + {size * op.count} > end',
                f'array of {op.count} elements runs past the end of the buffer ({{end}} bytes)',
            )
            src.add(f'{op.ref} = {self.array_expr(op.primitive, str(op.count), "pos")}')
            src.add(f'pos += {size * op.count}')
            return state.advance(size * op.count)
        if isinstance(op, _Str):
            # the count before it was marked with this path: the offset stays at the field start
            if op.wide:
                decode = src.ref(convert.wstring_decode, 'wstr')
                if op.bound:
                    self.fail(
                        f'{op.count} > {op.bound}',
                        f'wstring of {{{op.count}}} characters exceeds its bound {op.bound}',
                    )
                src.add(f'{op.ref}, pos = {decode}(buf, pos, {op.count}, end, {self.endian!r})')
                return _State(0, 4)
            with src.block(f'if {op.count}:'):
                src.add(f'e = pos + {op.count}')
                self.fail(
                    'e > end',
                    f'string of {{{op.count} - 1}} bytes runs past the end of the buffer '
                    '({end} bytes)',
                )
                self.fail('buf[e - 1]', 'string does not end with a NUL byte')
                if self.mv or self.trace:
                    src.add(f"{op.ref} = str(buf[pos:e - 1], 'utf-8')")
                else:
                    src.add(f'{op.ref} = buf[pos:e - 1].decode()')
                if op.bound:
                    # the bound counts bytes (C++ readers check that), but rclpy checks characters
                    # and writes longer strings: accept them when the characters fit
                    self.fail(
                        f'{op.count} > {op.bound + 1} and len({op.ref}) > {op.bound}',
                        f'string of {{len({op.ref})}} characters exceeds its bound {op.bound}',
                    )
                src.add('pos = e')
            with src.block('else:'):
                src.add(f"{op.ref} = ''")
            return _UNKNOWN
        if isinstance(op, _Seq):
            if op.bound >= 0:
                self.fail(
                    f'{op.count} > {op.bound}',
                    f'{{{op.count}}} elements exceed the bound {op.bound}',
                )
            if op.struct:
                info = self.ctx.info(op.element)
                align, stride = info.first_align, info.size
                dtype = src.ref(self.ctx.dtype(op.element, self.endian), 'D')
                cls = src.ref(self.ctx.cls(op.element), 'C')
                make = src.ref(_struct_seq_factory(), 'seq')
                empty = src.ref(convert.empty_array(self.ctx.dtype(op.element, self.endian)), 'E')
            else:
                align = stride = PRIMITIVE_SIZES[op.element]
                empty = src.ref(
                    convert.empty_array(
                        np.dtype('?')
                        if op.element == 'bool'
                        else numpy_dtype(op.element, self.endian)
                    ),
                    'E',
                )
            with src.block(f'if {op.count}:'):
                self.align(state, align)
                if op.struct:
                    view = f'{self.frombuffer}(buf, {dtype}, {op.count}, pos)'
                    src.add(f'{op.ref} = {make}({cls}, {view})')
                else:
                    src.add(f'{op.ref} = {self.array_expr(op.element, op.count, "pos")}')
                src.add(f'pos += {op.count}' if stride == 1 else f'pos += {op.count} * {stride}')
            with src.block('else:'):
                src.add(
                    f'{op.ref} = {make}({cls}, {empty})' if op.struct else f'{op.ref} = {empty}'
                )
            after = _State(0, min(align, 4)) if stride % min(align, 4) == 0 else _UNKNOWN
            return _merge_state(after, state)
        assert isinstance(op, _Loop)
        if op.count.isdigit():
            self.mark(op.path)
        items = src.tmp('l')
        append = src.tmp('a')
        src.add(f'{items} = []; {append} = {items}.append')
        if not op.count.isdigit():
            if op.bound >= 0:
                self.fail(
                    f'{op.count} > {op.bound}',
                    f'{{{op.count}}} elements exceed the bound {op.bound}',
                )
            self.fail(
                f'{op.count} > (end - pos) // {op.min_size}',
                f'{{{op.count}}} elements cannot fit in the {{end - pos}} bytes left',
            )
        with src.block(f'for {op.index} in range({op.count}):'):
            self.emit(op.body, _UNKNOWN)
            src.add(f'{append}({op.item})')
        src.add(f'{op.ref} = {items}')
        return _UNKNOWN


def _struct_seq_factory() -> Callable[[type, np.ndarray], Any]:
    from zros.cdr.message import StructSeq

    return StructSeq._from_array


def generate_decoder(
    ctx: Context, msg: MessageDef, endian: str, text_from_memoryview: bool, trace: bool
) -> Callable[[Any], Any]:
    """The function ``decode(buf, strict) -> message`` for the body after a valid header.

    It reads from offset 4 and ignores bytes left at the end, as DDS readers do (rclpy's
    serializer leaves up to 4 stray bytes per empty 8-byte sequence and per wstring). With
    ``strict`` at most 3 may be left (any number for types with a wstring): bag readers use that
    to tell whether an embedded definition matches its data.
    """
    builder = _DecoderBuilder(ctx, endian, text_from_memoryview, trace)
    src = builder.src
    cls = src.ref(ctx.cls(msg.name), 'C')
    ops: list[_Op] = []
    builder.struct_ops(msg, 'o', '', ops)
    src.add('end = len(buf)')
    src.add('pos = 4')
    if trace:
        src.add("_f = '(header)'; _p = 0")
        src.depth += 1
        body_start = len(src.lines)
    src.add(f'o = {builder.new}({cls})')
    builder.emit(ops, _START)
    if not ctx.info(msg.name).has_wstring:
        if trace:
            src.add("_f = ''; _p = pos")
        builder.fail(
            'strict and end - pos > 3',
            '{end - pos} bytes left after the end of the message (at most 3 padding bytes are '
            'allowed); the data may be of another type or version',
        )
    src.add('return o')
    if trace:
        body = src.lines[body_start:]
        del src.lines[body_start:]
        src.depth -= 1
        src.add('try:')
        src.lines.extend(body)
        src.add('except Exception as exc:')
        explain = src.ref(_decode_error, 'err')
        src.add(f'    raise {explain}({msg.name!r}, _f, _p, exc, end) from None')
    return src.compile('buf, strict=False', 'decode')


def _decode_error(type_name: str, path: str, offset: int, exc: Exception, size: int) -> Exception:
    from zros.cdr.errors import CdrError

    if isinstance(exc, CdrError):
        return exc
    reason = str(exc) or type(exc).__name__
    if isinstance(exc, struct.error) or (isinstance(exc, ValueError) and 'buffer' in reason):
        reason = f'the buffer ends too early ({size} bytes)'
    elif isinstance(exc, UnicodeDecodeError):
        reason = f'invalid UTF-8 ({exc.reason} at byte {exc.start} of the string)'
    where = f' field {path!r}' if path else ''
    return CdrError(
        f'cannot decode {type_name}:{where} at byte {offset}: {reason}',
        type_name=type_name,
        field=path,
        offset=offset,
    )


# --- encoding -----------------------------------------------------------------------------


@dataclass
class _Blob:
    """Variable-size bytes: a string body plus its NUL, a wstring body, or a sequence array."""

    ref: str
    size: str
    align: int  #: alignment of the data, applied only when the count is not 0
    count: str  #: the element count; the data is written only when it is not 0
    nul: bool  #: a string: write a NUL after the data
    conditional: bool  #: a sequence (aligned and written only when count > 0)


class _EncoderBuilder:
    def __init__(self, ctx: Context, trace: bool) -> None:
        self.ctx = ctx
        self.trace = trace
        self.src = _Source()
        self.bad = self.src.ref(convert.Bad, 'Bad')
        self.header_pending = True
        self.appends = 0
        self.last_append = -1
        self.single_pack = ''

    def struct_ops(self, msg: MessageDef, var: str, path: str, ops: list[_Op]) -> None:
        src = self.src
        if not msg.fields:
            ops.append(_Fix('x', 1, None, path or '(empty message)'))
            return
        for f in msg.fields:
            expr = f'{var}.{attribute_name(f.name)}'
            fpath = f'{path}.{f.name}' if path else f.name
            t = f.type
            if t.kind is Kind.SCALAR:
                self.scalar_ops(t, expr, fpath, ops)
                continue
            if t.kind is Kind.ARRAY:
                if t.is_primitive:
                    array = src.tmp('a')
                    fixed = src.ref(convert.fixed_array, 'fixed')
                    dtype = src.ref(_value_dtype(t.base), 'D')
                    ops.append(
                        _Pre(
                            [
                                *self.mark_lines(fpath),
                                f'{array} = {fixed}({expr}, {dtype}, {t.length})',
                            ]
                        )
                    )
                    ops.append(_FixArr(t.base, t.length, array, fpath))
                else:
                    items = src.tmp('l')
                    lines = [*self.mark_lines(fpath), f'{items} = {expr}']
                    lines.append(
                        f'if len({items}) != {t.length}: raise {self.bad}'
                        + (
                            f'(f"expected exactly {t.length} elements, got {{len({items})}}")'
                            if self.trace
                            else ''
                        )
                    )
                    ops.append(_Pre(lines))
                    ops.append(self.loop(t, items, fpath))
                continue
            bound = t.length if t.kind is Kind.BOUNDED else -1
            count = src.tmp('n')
            if t.is_primitive or (t.is_nested and self.ctx.info(t.base).uniform):
                array = src.tmp('a')
                if t.is_primitive:
                    convert_to = src.ref(convert.prim_array, 'prim')
                    target = src.ref(_value_dtype(t.base), 'D')
                    align = size = PRIMITIVE_SIZES[t.base]
                else:
                    convert_to = src.ref(_struct_array_factory(), 'sarr')
                    target = src.ref(self.ctx.cls(t.base), 'C')
                    info = self.ctx.info(t.base)
                    align, size = info.first_align, info.size
                ops.append(
                    _Pre(
                        [
                            *self.mark_lines(fpath),
                            f'{array} = {convert_to}({expr}, {target}, {bound})',
                            f'{count} = len({array})',
                        ]
                    )
                )
                ops.append(_Fix('I', 4, count, fpath))
                total = count if size == 1 else f'{count} * {size}'
                ops.append(_Blob(array, total, align, count, False, True))
            else:
                items = src.tmp('l')
                lines = [*self.mark_lines(fpath), f'{items} = {expr}', f'{count} = len({items})']
                if bound >= 0:
                    lines.append(
                        f'if {count} > {bound}: raise {self.bad}'
                        + (
                            f'(f"{{{count}}} elements exceed the bound of {bound}")'
                            if self.trace
                            else ''
                        )
                    )
                ops.append(_Pre(lines))
                ops.append(_Fix('I', 4, count, fpath))
                ops.append(self.loop(t, items, fpath))

    def mark_lines(self, path: str) -> list[str]:
        return [f'_f = {_path_literal(path)}'] if self.trace else []

    def scalar_ops(self, t: FieldType, expr: str, path: str, ops: list[_Op]) -> None:
        src = self.src
        if t.is_primitive:
            ops.append(_Fix(STRUCT_CODES[t.base], PRIMITIVE_SIZES[t.base], expr, path, t.base))
        elif t.base == 'string':
            data = src.tmp('s')
            count = src.tmp('n')
            lines = [*self.mark_lines(path)]
            if self.trace:
                lines.append(
                    f'if type({expr}) is not str: raise {self.bad}'
                    f'(f"expected str, got {{type({expr}).__name__}}")'
                )
            lines += [f'{data} = {expr}.encode()', f'{count} = len({data})']
            if t.string_bound:
                lines.append(
                    f'if {count} > {t.string_bound}: raise {self.bad}'
                    + (
                        f'(f"string of {{{count}}} bytes exceeds its bound {t.string_bound}")'
                        if self.trace
                        else ''
                    )
                )
            ops.append(_Pre(lines))
            ops.append(_Fix('I', 4, f'{count} + 1', path))
            ops.append(_Blob(data, f'{count} + 1', 1, count, True, False))
        elif t.base == 'wstring':
            data = src.tmp('s')
            count = src.tmp('n')
            encode = src.ref(convert.wstring_encode, 'wenc')
            lines = [*self.mark_lines(path), f'{data}, {count} = {encode}({expr})']
            if t.string_bound:
                lines.append(
                    f'if {count} > {t.string_bound}: raise {self.bad}'
                    + (
                        f'(f"wstring of {{{count}}} characters exceeds its bound {t.string_bound}")'
                        if self.trace
                        else ''
                    )
                )
            ops.append(_Pre(lines))
            ops.append(_Fix('I', 4, count, path))
            ops.append(_Blob(data, f'4 * {count}', 1, count, False, False))
        else:
            var = src.tmp('v')
            lines = [*self.mark_lines(path), f'{var} = {expr}']
            if self.trace:
                lines.append(
                    f"if getattr({var}, '__msgtype__', None) != {t.base!r}: raise {self.bad}"
                    f"(f'expected {t.base}, got {{type({var}).__name__}}')"
                )
            ops.append(_Pre(lines))
            self.struct_ops(self.ctx.resolve(t.base), var, path, ops)

    def loop(self, t: FieldType, items: str, path: str) -> _Loop:
        index = self.src.tmp('i')
        item = self.src.tmp('e')
        body: list[_Op] = []
        self.scalar_ops(t.element, item, f'{path}[{{{index}}}]', body)
        return _Loop(items, -1, 1, '', item, index, body, path)

    # emission

    def ensure_header(self) -> None:
        """Write the header now unless it was already written (or folded into a pack)."""
        if self.header_pending:
            self.header_pending = False
            self.append(self.src.ref(HEADER_LE, 'H'))

    def append(self, expr: str) -> None:
        self.ensure_header()
        self.appends += 1
        self.last_append = len(self.src.lines)
        self.src.add(f'_p({expr})')

    def align(self, state: _State, align: int) -> _State:
        pad = state.static_pad(align)
        if pad is None:
            self.src.add(f'k = -r & {align - 1}')
            with self.src.block('if k:'):
                self.append(f'{self.src.ref(_ZEROS, "Z")}[k]')
                self.src.add('r += k')
            return _State(0, align)
        if pad:
            self.append(self.src.ref(bytes(pad), 'Z'))
            self.src.add(f'r += {pad}')
        return state.advance(pad)

    def emit(self, ops: list[_Op], state: _State) -> _State:
        run: list[tuple[int, _Fix | _FixArr]] = []
        run_state = state
        offset = 0
        dynamic = 0  # alignment applied dynamically before the run (0: none)
        for op in ops:
            if isinstance(op, _Pre):
                for line in op.lines:
                    self.src.add(line)
                continue
            if isinstance(op, (_Fix, _FixArr)):
                if self.trace and isinstance(op, _Fix):
                    if run:
                        state = self.flush(run, run_state, offset, dynamic)
                        run = []
                    self.src.add(f'_f = {_path_literal(op.path)}')
                    if op.primitive and op.ref is not None:
                        check = self.src.ref(convert.check_scalar, 'chk')
                        low, high = INTEGER_RANGES.get(op.primitive, (None, None))
                        self.src.add(f'{check}({op.primitive!r}, {op.ref}, {low}, {high})')
                size = PRIMITIVE_SIZES[op.primitive] if isinstance(op, _FixArr) else op.size
                align = 1 if isinstance(op, _Fix) and op.code in 'x?' else size
                if run and run_state.modulus >= align:
                    offset += -(run_state.mod + offset) % align
                else:
                    if run:
                        state = self.flush(run, run_state, offset, dynamic)
                        run = []
                    pad = state.static_pad(align)
                    dynamic = 0
                    if pad is None:
                        dynamic = align
                        self.src.add(f'k = -r & {align - 1}')
                        state = _State(0, align)
                        pad = 0
                    run_state = state
                    offset = pad
                run.append((offset, op))
                offset += size * (op.count if isinstance(op, _FixArr) else 1)
                continue
            if run:
                state = self.flush(run, run_state, offset, dynamic)
                run = []
            state = self.emit_one(op, state)
        if run:
            state = self.flush(run, run_state, offset, dynamic)
        return state

    def flush(
        self, run: list[tuple[int, _Fix | _FixArr]], state: _State, total: int, dynamic: int
    ) -> _State:
        """Write a run: pack calls for scalars, array buffers between them."""
        src = self.src
        segments: list[
            tuple[str, Any]
        ] = []  # ('pack', (fmt parts, values)) / ('array', ref) / ('zeros', n)
        position = 0
        for offset, op in run:
            pad = offset - position
            if isinstance(op, _FixArr):
                if pad:
                    if segments and segments[-1][0] == 'pack':
                        segments[-1][1][0].append(f'{pad}x')
                    else:
                        segments.append(('zeros', pad))
                segments.append(('array', op.ref))
                position = offset + PRIMITIVE_SIZES[op.primitive] * op.count
                continue
            if not segments or segments[-1][0] != 'pack':
                segments.append(('pack', ([], [])))
            fmt, values = segments[-1][1]
            if pad:
                fmt.append(f'{pad}x')
            fmt.append(op.code)
            if op.ref is not None:
                values.append(op.ref)
            position = offset + op.size
        if total > position:
            if segments[-1][0] == 'pack':
                segments[-1][1][0].append(f'{total - position}x')
            else:
                segments.append(('zeros', total - position))
        for index, (kind, data) in enumerate(segments):
            first = index == 0
            if kind == 'pack':
                fmt, values = data
                body = ''.join(fmt)
                if first and dynamic:
                    variants = tuple(struct.Struct(f'<{k}x{body}') for k in range(dynamic))
                    packer = f'{src.ref(variants, "V")}[k]'
                elif first and self.header_pending and src.depth == 1 and not dynamic:
                    packer = src.ref(struct.Struct('<4s' + body), 'S')
                    values = [src.ref(HEADER_LE, 'H'), *values]
                    self.header_pending = False
                else:
                    packer = src.ref(struct.Struct('<' + body), 'S')
                expr = f'{packer}.pack({", ".join(values)})'
                if not self.single_pack and self.appends == 0 and len(segments) == 1:
                    self.single_pack = expr
                self.append(expr)
            elif kind == 'array':
                if first and dynamic:
                    with src.block('if k:'):
                        self.append(f'{src.ref(_ZEROS, "Z")}[k]')
                self.append(data)
            else:
                if first and dynamic:
                    with src.block('if k:'):
                        self.append(f'{src.ref(_ZEROS, "Z")}[k]')
                self.append(src.ref(bytes(data), 'Z'))
        src.add(f'r += k + {total}' if dynamic else f'r += {total}')
        return state.advance(total)

    def emit_one(self, op: _Op, state: _State) -> _State:
        src = self.src
        if isinstance(op, _Blob):
            if op.nul:
                self.append(op.ref)
                self.append(src.ref(b'\x00', 'NUL'))
                src.add(f'r += {op.size}')
                return _UNKNOWN
            if not op.conditional:
                self.append(op.ref)
                src.add(f'r += {op.size}')
                return _State(0, 4)
            self.ensure_header()
            with src.block(f'if {op.count}:'):
                self.align(state, op.align)
                self.append(op.ref)
                src.add(f'r += {op.size}')
            after = _State(0, min(op.align, 4))
            return _merge_state(after, state)
        assert isinstance(op, _Loop)
        self.ensure_header()
        with src.block(
            f'for {op.index}, {op.item} in enumerate({op.count}):'
            if self.trace
            else f'for {op.item} in {op.count}:'
        ):
            self.emit(op.body, _UNKNOWN)
        return _UNKNOWN


_ZEROS = tuple(bytes(k) for k in range(8))


def _value_dtype(primitive: str) -> np.dtype:
    return np.dtype('?') if primitive == 'bool' else numpy_dtype(primitive, '<')


def _struct_array_factory() -> Callable[[Any, type, int], np.ndarray]:
    from zros.cdr.message import struct_array

    return struct_array


def generate_encoder(ctx: Context, msg: MessageDef, trace: bool) -> Callable[..., bytes]:
    """The function ``encode(message, join=b''.join) -> bytes`` (little-endian, header included,
    no padding). ``join`` assembles the parts; publishers pass one that reuses a buffer."""
    builder = _EncoderBuilder(ctx, trace)
    src = builder.src
    ops: list[_Op] = []
    builder.struct_ops(msg, 'o', '', ops)
    src.add('parts = []; _p = parts.append; r = 0')
    if trace:
        src.add("_f = ''")
        src.depth += 1
        start = len(src.lines)
    builder.emit(ops, _START)
    builder.ensure_header()
    src.add('return join(parts)')
    if trace:
        body = src.lines[start:]
        del src.lines[start:]
        src.depth -= 1
        src.add('try:')
        src.lines.extend(body)
        src.add('except Exception as exc:')
        explain = src.ref(_encode_error, 'err')
        src.add(f'    raise {explain}({msg.name!r}, _f, exc) from None')
    elif builder.appends == 1 and builder.single_pack:
        # the whole message is one pack call: return its bytes, no parts list
        lines = src.lines[: builder.last_append]
        del lines[0]
        src.lines = [*lines, f'    return {builder.single_pack}']
    join_default = src.ref(b''.join, 'join')
    return src.compile(f'o, join={join_default}', 'encode')


def _encode_error(type_name: str, path: str, exc: Exception) -> Exception:
    from zros.cdr.errors import CdrError

    if isinstance(exc, CdrError):
        return exc
    reason = str(exc) or type(exc).__name__
    if isinstance(exc, AttributeError):
        reason = f'a value has the wrong type ({reason})'
    where = f' field {path!r}' if path else ''
    return CdrError(f'cannot encode {type_name}:{where}: {reason}', type_name=type_name, field=path)


# --- class methods ------------------------------------------------------------------------


def _display_name(name: str) -> str:
    return name.replace('/', '.')


def generate_methods(ctx: Context, msg: MessageDef) -> dict[str, Callable[..., Any]]:
    """``__init__``, ``__eq__``, ``__repr__``, ``copy`` and ``to_dict`` of a message class.

    For uniform structs also ``_from_tuple`` and ``_to_tuple`` (rows of its numpy dtype).
    """
    result: dict[str, Callable[..., Any]] = {
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


def _scalar_check(t: FieldType, attr: str, type_: str, src: _Source) -> str:
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


def _default_expr(ctx: Context, src: _Source, f: Any, category: str) -> str:
    """The expression of a field's default value (a fresh object for mutable ones)."""
    t = f.type
    if category in ('prim', 'str'):
        default = f.default
        if default is None:
            zero = 0.0 if t.base.startswith('float') else False if t.base == 'bool' else 0
            default = '' if t.is_string else zero
        return repr(default) if isinstance(default, (bool, int)) else src.ref(default, 'd')
    if category == 'prim_array':
        dtype = src.ref(_value_dtype(t.base), 'D')
        if f.default is not None:
            return f'{src.ref(np.array, "array")}({src.ref(f.default, "d")}, {dtype})'
        if t.kind is Kind.ARRAY:
            return f'{src.ref(np.zeros, "zeros")}({t.length}, {dtype})'
        return src.ref(convert.empty_array(_value_dtype(t.base)), 'E')
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
    return f'{src.ref(_struct_seq_class(), "Seq")}({cls})'


def _gen_default(ctx: Context, msg: MessageDef) -> Callable[[], Any]:
    """A message with every default value, made without the constructor's checks (nested
    defaults use it: they need no checking, and ``Msg()`` of a nested type costs twice as much)."""
    src = _Source()
    src.add(f'o = {src.ref(object.__new__, "new")}({src.ref(ctx.cls(msg.name), "C")})')
    for f in msg.fields:
        value = _default_expr(ctx, src, f, _field_category(ctx, f.type))
        src.add(f'o.{attribute_name(f.name)} = {value}')
    src.add('return o')
    return src.compile('', '_zros_default')


def _gen_init(ctx: Context, msg: MessageDef) -> Callable[..., None]:
    # parameters are field names, which may shadow builtins: generated code uses only _names.
    # Each scalar argument passes one cheap test (its exact type); anything else goes to a
    # convert helper that converts it (an int for a float...) or raises a FieldError.
    src = _Source()
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
            dtype = src.ref(_value_dtype(t.base), 'D')
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
                items = src.ref(convert.struct_items, 'items')
                seq = src.ref(_struct_seq_class(), 'Seq')
                value = f'{seq}({cls}, {items}({cls}, {attr}, {shape[1]}, {where}))'
        src.add(f'{target} = {default} if {attr} is {missing} else {value}')
    signature = ', '.join(['_self', *params, '**_extra'])
    init = src.compile(signature, '__init__')
    init.__qualname__ = f'{msg.name.rsplit("/", 1)[1]}.__init__'
    return init


def _unknown_field(type_name: str, fields: tuple[str, ...], extra: dict[str, Any]) -> Exception:
    from zros.cdr.errors import FieldError

    return FieldError.unknown(type_name, next(iter(extra)), fields)


_MISSING = object()


def _struct_seq_class() -> type:
    from zros.cdr.message import StructSeq

    return StructSeq


def _gen_eq(ctx: Context, msg: MessageDef) -> Callable[[Any, Any], Any]:
    src = _Source()
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


def _array_equal(a: Any, b: Any) -> bool:
    return bool(np.array_equal(a, b))


def _gen_repr(ctx: Context, msg: MessageDef) -> Callable[[Any], str]:
    src = _Source()
    parts = ', '.join(
        f'{attribute_name(f.name)}={{self.{attribute_name(f.name)}!r}}' for f in msg.fields
    )
    src.add(f'return f{_display_name(msg.name) + "(" + parts + ")"!r}')
    return src.compile('self', '__repr__')


def _gen_copy(ctx: Context, msg: MessageDef) -> Callable[[Any], Any]:
    src = _Source()
    cls = src.ref(ctx.cls(msg.name), 'C')
    src.add(f'o = {src.ref(object.__new__, "new")}({cls})')
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


def _to_list(value: Any) -> list[Any]:
    return value.tolist() if isinstance(value, np.ndarray) else list(value)


def _gen_to_dict(ctx: Context, msg: MessageDef) -> Callable[[Any], dict[str, Any]]:
    src = _Source()
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


def _tuple_pattern(ctx: Context, msg: MessageDef, src: _Source, var: str, lines: list[str]) -> str:
    """Unpacking pattern of one dtype row; appends to ``lines`` the code building ``var``."""
    cls = src.ref(ctx.cls(msg.name), 'C')
    new = src.ref(object.__new__, 'new')
    lines.append(f'{var} = {new}({cls})')
    names = []
    for f in msg.fields:
        attr = attribute_name(f.name)
        t = f.type
        if t.is_primitive:
            name = src.tmp('x')
            names.append(name)
            if t.kind is Kind.ARRAY:
                dtype = src.ref(_value_dtype(t.base), 'D')
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
            sub_source = _Source()
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


def _gen_from_tuple(ctx: Context, msg: MessageDef) -> Callable[[Any], Any]:
    src = _Source()
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


def _gen_to_tuple(ctx: Context, msg: MessageDef) -> Callable[[Any], tuple[Any, ...]]:
    src = _Source()
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


def _gen_pack_rows(ctx: Context, msg: MessageDef) -> Callable[[Any], bytes] | None:
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
    src = _Source()
    pack = src.ref(struct.Struct(''.join(fmt)).pack, 'pack')
    src.add('out = []; ap = out.append')
    with src.block('for o in items:'):
        src.add(f'ap({pack}({", ".join(values)}))')
    src.add(f'return {src.ref(b"".join, "join")}(out)')
    return src.compile('items', '_pack_rows')


def source_of(function: Callable[..., Any]) -> str:
    """The generated source of a codec or method (for debugging)."""
    return str(getattr(function, '__zros_source__', ''))
