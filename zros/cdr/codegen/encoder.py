"""The generated CDR encoder of a message type (the fast one and the traced one)."""

from __future__ import annotations

import struct
from contextlib import nullcontext
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from zros.cdr import convert
from zros.cdr.codegen.failures import encode_failure
from zros.cdr.codegen.ops import (
    START,
    STRUCT_CODES,
    UNKNOWN,
    Blob,
    Context,
    Fix,
    FixArr,
    Loop,
    LoopStates,
    Op,
    Pre,
    State,
    empty_message,
    fields_of,
    merge_state,
    value_dtype,
)
from zros.cdr.codegen.passes import JOIN, PARTS, parts_in_locals, without_dead_counts
from zros.cdr.codegen.program import Program, path_literal
from zros.cdr.model import INTEGER_RANGES, PRIMITIVE_SIZES, FieldType, Kind, MessageDef
from zros.cdr.struct_seq import struct_rows

if TYPE_CHECKING:
    from zros.cdr.encode_buffer import Join
    from zros.cdr.message import Message


class Encoder(Protocol):
    """A compiled encoder: ``encode(message, join=b''.join) -> bytes``."""

    def __call__(self, message: Message, join: Join = ..., /) -> bytes: ...


#: the CDR header of little-endian data
HEADER_LE = b'\x00\x01\x00\x00'


@dataclass
class _Pack:
    """One ``struct.pack`` call of a run: its format parts and the values' expressions."""

    fmt: list[str]
    values: list[str]


class _EncoderBuilder:
    def __init__(self, ctx: Context, trace: bool) -> None:
        self.ctx = ctx
        self.trace = trace
        self.src = Program()
        self.bad = self.src.ref(convert.Bad, 'Bad')
        self.header_pending = True
        self.appends = 0
        self.last_append = -1
        self.single_pack = ''
        self.loops = LoopStates(lambda loop, start: self.dry_emit(loop.body, start))

    def struct_ops(self, msg: MessageDef, var: str, path: str, ops: list[Op]) -> None:
        src = self.src
        if not msg.fields:
            ops.append(empty_message(path))
            return
        for expr, fpath, t in fields_of(msg, var, path):
            if t.kind is Kind.SCALAR:
                self.scalar_ops(t, expr, fpath, ops)
                continue
            if t.kind is Kind.ARRAY:
                if t.is_primitive:
                    array = src.tmp('a')
                    fixed = src.ref(convert.fixed_array, 'fixed')
                    dtype = src.ref(value_dtype(t.base), 'D')
                    ops.append(
                        Pre(
                            [
                                *self.mark_lines(fpath),
                                f'{array} = {fixed}({expr}, {dtype}, {t.length})',
                            ]
                        )
                    )
                    ops.append(FixArr(t.base, t.length, array, fpath))
                else:
                    items = src.tmp('l')
                    lines = [*self.mark_lines(fpath), f'{items} = {expr}']
                    lines.append(
                        self.refuse(
                            f'len({items}) != {t.length}',
                            f'expected exactly {t.length} elements, got {{len({items})}}',
                        )
                    )
                    ops.append(Pre(lines))
                    ops.append(self.loop(t, items, fpath))
                continue
            bound = t.length if t.kind is Kind.BOUNDED else -1
            count = src.tmp('n')
            if t.is_primitive or (t.is_nested and self.ctx.info(t.base).uniform):
                array = src.tmp('a')
                if t.is_primitive:
                    convert_to = src.ref(convert.prim_array, 'prim')
                    target = src.ref(value_dtype(t.base), 'D')
                    align = size = PRIMITIVE_SIZES[t.base]
                    lines = self.prim_lines(array, expr, convert_to, target, bound)
                    lines.append(f'{count} = len({array})')
                else:  # packed rows (bytes) or a structured array, and how many elements
                    convert_to = src.ref(struct_rows, 'srows')
                    target = src.ref(self.ctx.cls(t.base), 'C')
                    info = self.ctx.info(t.base)
                    align, size = info.first_align, info.size
                    lines = [f'{count}, {array} = {convert_to}({expr}, {target}, {bound})']
                ops.append(Pre([*self.mark_lines(fpath), *lines]))
                ops.append(Fix('I', 4, count, fpath))
                total = count if size == 1 else f'{count} * {size}'
                ops.append(Blob(array, total, align, count, False, True))
            else:
                items = src.tmp('l')
                lines = [*self.mark_lines(fpath), f'{items} = {expr}', f'{count} = len({items})']
                if bound >= 0:
                    lines.append(
                        self.refuse(
                            f'{count} > {bound}',
                            f'{{{count}}} elements exceed the bound of {bound}',
                        )
                    )
                ops.append(Pre(lines))
                ops.append(Fix('I', 4, count, fpath))
                ops.append(self.loop(t, items, fpath))

    def prim_lines(
        self, array: str, expr: str, convert_to: str, dtype: str, bound: int
    ) -> list[str]:
        """``array`` = the value of a primitive sequence as an array to write. The fast encoder
        tests the usual case (a contiguous 1-D array of the field's dtype) inline: the call
        it saves is a tenth of a small message's encoding."""
        if self.trace:
            return [f'{array} = {convert_to}({expr}, {dtype}, {bound})']
        ndarray = self.src.ref(np.ndarray, 'nd')
        usual = (
            f'type({array}) is {ndarray} and {array}.dtype is {dtype} and {array}.ndim == 1 '
            f'and {array}.flags.c_contiguous'
        )
        lines = [f'{array} = {expr}']
        if bound >= 0:
            lines.append(f'if not ({usual}) or len({array}) > {bound}:')
        else:
            lines.append(f'if not ({usual}):')
        lines.append(f'    {array} = {convert_to}({array}, {dtype}, {bound})')
        return lines

    def refuse(self, condition: str, reason: str) -> str:
        """A line raising ``Bad`` when ``condition`` holds (with ``reason``, an f-string body
        without double quotes, when traced)."""
        return f'if {condition}: raise {self.bad}' + (f'(f"{reason}")' if self.trace else '')

    def mark_lines(self, path: str) -> list[str]:
        return [f'_f = {path_literal(path)}'] if self.trace else []

    def scalar_ops(self, t: FieldType, expr: str, path: str, ops: list[Op]) -> None:
        src = self.src
        if t.is_primitive:
            ops.append(Fix(STRUCT_CODES[t.base], PRIMITIVE_SIZES[t.base], expr, path, t.base))
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
                    self.refuse(
                        f'{count} > {t.string_bound}',
                        f'string of {{{count}}} bytes exceeds its bound {t.string_bound}',
                    )
                )
            ops.append(Pre(lines))
            ops.append(Fix('I', 4, f'{count} + 1', path))
            ops.append(Blob(data, f'{count} + 1', 1, count, True, False))
        elif t.base == 'wstring':
            data = src.tmp('s')
            count = src.tmp('n')
            encode = src.ref(convert.wstring_encode, 'wenc')
            lines = [*self.mark_lines(path), f'{data}, {count} = {encode}({expr})']
            if t.string_bound:
                lines.append(
                    self.refuse(
                        f'{count} > {t.string_bound}',
                        f'wstring of {{{count}}} characters exceeds its bound {t.string_bound}',
                    )
                )
            ops.append(Pre(lines))
            ops.append(Fix('I', 4, count, path))
            ops.append(Blob(data, f'4 * {count}', 1, count, False, False))
        else:
            var = src.tmp('v')
            lines = [*self.mark_lines(path), f'{var} = {expr}']
            if self.trace:
                lines.append(
                    f"if getattr({var}, '__msgtype__', None) != {t.base!r}: raise {self.bad}"
                    f"(f'expected {t.base}, got {{type({var}).__name__}}')"
                )
            ops.append(Pre(lines))
            self.struct_ops(self.ctx.resolve(t.base), var, path, ops)

    def loop(self, t: FieldType, items: str, path: str) -> Loop:
        index = self.src.tmp('i')
        item = self.src.tmp('e')
        body: list[Op] = []
        self.scalar_ops(t.element, item, f'{path}[{{{index}}}]', body)
        return Loop(items, -1, 1, '', item, index, body, path)

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

    def align(self, state: State, align: int) -> State:
        pad = state.static_pad(align)
        if pad is None:
            self.src.add(f'k = -r & {align - 1}')
            with self.src.block('if k:'):
                self.append(f'{self.src.ref(_ZEROS, "Z")}[k]')
                self.src.add('r += k')
            return State(0, align)
        if pad:
            self.append(self.src.ref(bytes(pad), 'Z'))
            self.src.add(f'r += {pad}')
        return state.advance(pad)

    def emit(self, ops: list[Op], state: State) -> State:
        run: list[tuple[int, Fix | FixArr]] = []
        run_state = state
        offset = 0
        dynamic = 0  # alignment applied dynamically before the run (0: none)
        for op in ops:
            if isinstance(op, Pre):
                for line in op.lines:
                    self.src.add(line)
                continue
            if isinstance(op, (Fix, FixArr)):
                if self.trace and isinstance(op, Fix):
                    if run:
                        state = self.flush(run, run_state, offset, dynamic)
                        run = []
                    self.src.add(f'_f = {path_literal(op.path)}')
                    if op.primitive and op.ref is not None:
                        check = self.src.ref(convert.check_scalar, 'chk')
                        low, high = INTEGER_RANGES.get(op.primitive, (None, None))
                        self.src.add(f'{check}({op.primitive!r}, {op.ref}, {low}, {high})')
                size = PRIMITIVE_SIZES[op.primitive] if isinstance(op, FixArr) else op.size
                align = 1 if isinstance(op, Fix) and op.code in 'x?' else size
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
                        state = State(0, align)
                        pad = 0
                    run_state = state
                    offset = pad
                run.append((offset, op))
                offset += size * (op.count if isinstance(op, FixArr) else 1)
                continue
            if run:
                state = self.flush(run, run_state, offset, dynamic)
                run = []
            state = self.emit_one(op, state)
        if run:
            state = self.flush(run, run_state, offset, dynamic)
        return state

    def flush(
        self, run: list[tuple[int, Fix | FixArr]], state: State, total: int, dynamic: int
    ) -> State:
        """Write a run: pack calls for scalars, array buffers between them."""
        src = self.src
        # a pack call (_Pack), an array's reference (str) or zero padding (a count of bytes)
        segments: list[_Pack | str | int] = []
        position = 0
        for offset, op in run:
            pad = offset - position
            if isinstance(op, FixArr):
                if pad:
                    if segments and isinstance(segments[-1], _Pack):
                        segments[-1].fmt.append(f'{pad}x')
                    else:
                        segments.append(pad)
                segments.append(op.ref)
                position = offset + PRIMITIVE_SIZES[op.primitive] * op.count
                continue
            last = segments[-1] if segments else None
            if not isinstance(last, _Pack):
                last = _Pack([], [])
                segments.append(last)
            if pad:
                last.fmt.append(f'{pad}x')
            last.fmt.append(op.code)
            if op.ref is not None:
                last.values.append(op.ref)
            position = offset + op.size
        if total > position:
            if isinstance(segments[-1], _Pack):
                segments[-1].fmt.append(f'{total - position}x')
            else:
                segments.append(total - position)
        for index, data in enumerate(segments):
            first = index == 0
            if isinstance(data, _Pack):
                values = data.values
                body = ''.join(data.fmt)
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
            elif isinstance(data, str):
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

    def emit_one(self, op: Op, state: State) -> State:
        src = self.src
        if isinstance(op, Blob):
            if op.nul:
                self.append(op.ref)
                self.append(src.ref(b'\x00', 'NUL'))
                src.add(f'r += {op.size}')
                return UNKNOWN
            if not op.conditional:
                self.append(op.ref)
                src.add(f'r += {op.size}')
                return State(0, 4)
            self.ensure_header()
            with src.block(f'if {op.count}:'):
                self.align(state, op.align)
                self.append(op.ref)
                src.add(f'r += {op.size}')
            after = State(0, min(op.align, 4))
            return merge_state(after, state)
        assert isinstance(op, Loop)
        self.ensure_header()
        entry = self.loops.entry(op, state)
        if self.src.trials:  # a dry run needs only the state after the loop
            return entry
        with src.block(
            f'for {op.index}, {op.item} in enumerate({op.count}):'
            if self.trace
            else f'for {op.item} in {op.count}:'
        ):
            self.emit(op.body, entry)
        return entry

    def dry_emit(self, ops: list[Op], state: State) -> State:
        """The state ``emit(ops, state)`` would leave, emitting nothing."""
        counts = self.appends, self.last_append
        with self.src.trial():
            end = self.emit(ops, state)
        self.appends, self.last_append = counts
        return end


_ZEROS = tuple(bytes(k) for k in range(8))


def generate_encoder(ctx: Context, msg: MessageDef, trace: bool) -> Encoder:
    """The function ``encode(message, join=b''.join) -> bytes`` (little-endian, header included,
    no padding). ``join`` assembles the parts; publishers pass one that reuses a buffer."""
    builder = _EncoderBuilder(ctx, trace)
    src = builder.src
    ops: list[Op] = []
    builder.struct_ops(msg, 'o', '', ops)
    src.add(PARTS)
    if trace:
        src.add("_f = ''")
    with src.guarded(encode_failure, f'{msg.name!r}, _f, exc') if trace else nullcontext():
        builder.emit(ops, START)
        builder.ensure_header()
        src.add(JOIN)
    if not trace and builder.appends == 1 and builder.single_pack:
        # the whole message is one pack call: return its bytes, no parts list
        lines = src.lines[: builder.last_append]
        del lines[0]
        src.lines = [*lines, f'    return {builder.single_pack}']
    elif not trace:
        src.lines = without_dead_counts(src.lines)
        src.lines = parts_in_locals(src.lines) or src.lines
    join_default = src.ref(b''.join, 'join')
    return src.compile(f'o, join={join_default}', 'encode', msg.name)
