"""The builder of a decoder's source: reads of fields, strings, arrays and loops, in the fast
and the traced form (:mod:`zros.cdr.codegen.decoder` puts a type's decoder together)."""

from __future__ import annotations

import struct
from typing import TYPE_CHECKING

import numpy as np

from zros.cdr import convert
from zros.cdr.codegen.ops import (
    UNKNOWN,
    Context,
    Fix,
    FixArr,
    Loop,
    LoopStates,
    Op,
    Pre,
    Seq,
    State,
    Str,
    merge_state,
)
from zros.cdr.codegen.program import Program, path_literal
from zros.cdr.layout import numpy_dtype
from zros.cdr.model import PRIMITIVE_SIZES
from zros.cdr.struct_seq import StructSeq

if TYPE_CHECKING:
    pass


#: a memoryview of a message with arrays and text before them has this many bytes copied
#: to ``bytes`` once (with its first run of fixed fields: 25 ns; alone: 110 ns), and its text
#: and fixed fields up to the first array read from the copy: a string read from a view costs
#: 60-100 ns more than from bytes. Headers, frame
#: ids, encodings and PointCloud2's fields fit; a head reaching past it raises, and the view
#: is read by the fallback
HEAD_BYTES = 256


def reads_buffer(op: Op) -> bool:
    """Whether ``op`` reads from the buffer itself, never from a head copy: arrays view it,
    and wstrings are decoded from it."""
    if isinstance(op, Loop):
        return any(reads_buffer(inner) for inner in op.body)
    return isinstance(op, (FixArr, Seq)) or (isinstance(op, Str) and op.wide)


def _dynamic_align(align: int) -> str:
    if align == 8:
        return 'pos += (4 - pos) & 7'
    if align == 4:
        return 'pos += -pos & 3'
    return 'pos += pos & 1'


class DecoderBuilder:
    """The source of one decoder under construction: the reads of its fields in order, the
    offset known so far, and the fast or traced form (``trace``) of a bytes or memoryview
    (``memory``) decoder."""

    def __init__(
        self, ctx: Context, endian: str, memory: bool, trace: bool, src: Program | None = None
    ) -> None:
        self.ctx = ctx
        self.endian = endian
        self.memory = memory
        self.trace = trace
        self.src = src or Program()
        self.bad = self.src.ref(convert.Bad, 'Bad')
        self.frombuffer = self.src.ref(np.frombuffer, 'fb')
        #: the read offset while known when generating (the fast decoder reads the fixed fields
        #: before the first variable-size one at constant offsets); None once ``pos`` holds it
        self.static: int | None = None if trace else 4
        #: the buffer's size in bytes: the traced decoder keeps it in ``end`` for its messages;
        #: a memoryview's ``len`` counts items, which need not be bytes
        self.end = 'end' if trace else 'buf.nbytes' if memory else 'len(buf)'
        #: what fixed fields, strings and NUL bytes are read from: ``buf``, or ``hd``, the
        #: ``bytes`` copy of a memoryview's head (:data:`HEAD_BYTES`) until its first array
        self.source = 'buf'
        #: the offset in the buffer of ``hd``'s first byte (``pos`` counts from it meanwhile)
        self.base = 0
        #: whether the first run of fixed fields copies the head too (:meth:`flush`)
        self.head_pending = False
        #: the fallback of a decoder that checks the header itself, while its first run of
        #: fixed fields (which then reads the header too) is still to come
        self.header_fallback: str | None = None
        #: in a decoder of a private ``bytes`` copy, texts longer than this decode from a
        #: memoryview of it (one pass over the text instead of a slice's copy and a decode)
        self.long_text: int | None = None
        self.loops = LoopStates(lambda loop, start: self.dry_emit(loop.body, start))

    # emission

    def where(self, delta: int = 0) -> str:
        """The expression of the read offset plus ``delta``."""
        if self.static is not None:
            return str(self.static + delta)
        return f'pos + {delta}' if delta else 'pos'

    def skip(self, size: int) -> None:
        if self.static is not None:
            self.static += size
        elif size:
            self.src.add(f'pos += {size}')

    def materialize(self) -> None:
        """Store the offset known so far in ``pos`` (before code that moves it at run time)."""
        if self.static is not None:
            self.src.add(f'pos = {self.static}')
            self.static = None

    def align(self, state: State, align: int) -> State:
        pad = state.static_pad(align)
        if pad is None:
            assert self.static is None  # a known offset keeps the state exact
            self.src.add(_dynamic_align(align))
            return State(0, align)
        self.skip(pad)
        return state.advance(pad)

    def mark(self, path: str) -> None:
        if self.trace:
            self.src.add(f'_f = {path_literal(path)}; _p = pos')

    def emit(self, ops: list[Op], state: State) -> State:
        run: list[tuple[int, Fix | FixArr]] = []
        run_state = state
        offset = 0
        for op in ops:
            if isinstance(op, Pre):
                for line in op.lines:
                    self.src.add(line)
                continue
            if isinstance(op, (Fix, FixArr)) and not self.trace:
                size = PRIMITIVE_SIZES[op.primitive] if isinstance(op, FixArr) else op.size
                align = 1 if isinstance(op, Fix) and op.code == 'x' else size
                if run and run_state.modulus >= align:
                    offset += -(run_state.mod + offset) % align
                else:
                    if run:
                        state = self.flush(run, run_state, offset)
                        run = []
                    pad = state.static_pad(align)
                    if pad is None:
                        assert self.static is None
                        self.src.add(_dynamic_align(align))
                        state = State(0, align)
                        pad = 0
                    run_state = state
                    offset = pad
                run.append((offset, op))
                offset += size * (op.count if isinstance(op, FixArr) else 1)
                continue
            if run:
                state = self.flush(run, run_state, offset)
                run = []
            state = self.emit_one(op, state)
        if run:
            state = self.flush(run, run_state, offset)
        return state

    def flush(self, run: list[tuple[int, Fix | FixArr]], state: State, total: int) -> State:
        fmt = [self.endian]
        targets: list[str] = []
        arrays: list[tuple[int, FixArr]] = []
        position = 0
        header = self.header_fallback if self.static == 4 else None
        if header is not None:  # the run starts the body: read the 2 header bytes with it
            fmt.append('H2x')
            targets.append('h')
            self.header_fallback = None
        split = self.head_pending and self.static == 4 and (4 + total) % 8 == 0
        if self.head_pending and not split:
            self.src.add(f'hd = buf[:{HEAD_BYTES}].tobytes()')
            self.source = 'hd'
        self.head_pending = False
        for offset, op in run:
            if offset > position:
                fmt.append(f'{offset - position}x')
            if isinstance(op, FixArr):
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
        if arrays:  # arrays view the buffer, and the run may reach past the head
            self.to_buffer()
        start = '0' if header is not None else self.where()
        if split:
            self.split_head(fmt, targets, total)
        elif targets:
            self.src.add(f'{", ".join(targets)}, = {packer}.unpack_from({self.source}, {start})')
        else:
            self.src.add(f'{packer}.unpack_from({self.source}, {start})')
        if header is not None:  # 00 01, plain little-endian CDR, reads as 256
            self.src.add(f'if h != 256: return {header}(buf, strict)')
        self.fixed_arrays(arrays)
        self.skip(total)
        if split:  # the offsets count from the head copy's start until the first array
            assert self.static is not None
            self.base, self.static = self.static, 0
        return state.advance(total)

    def split_head(self, fmt: list[str], targets: list[str], total: int) -> None:
        """The first run of fixed fields, read from offset 0 with the :data:`HEAD_BYTES` after
        it as ``hd`` in the same ``unpack_from`` (a copy of its own would cost 60 ns more);
        from a view no longer than those, ``hd`` copies the rest."""
        src = self.src
        after = 4 + total
        names = ''.join(f'{target}, ' for target in targets)
        long = src.ref(struct.Struct(''.join(fmt) + f'{HEAD_BYTES}s'), 'S')
        short = src.ref(struct.Struct(''.join(fmt)), 'S')
        with src.block(f'if buf.nbytes > {after + HEAD_BYTES}:'):
            src.add(f'{names}hd, = {long}.unpack_from(buf, 0)')
        with src.block('else:'):
            src.add(
                f'{names}= {short}.unpack_from(buf, 0)' if names else f'{short}.unpack_from(buf, 0)'
            )
            src.add(f'hd = buf[{after}:].tobytes()')
        self.source = 'hd'

    def to_buffer(self) -> None:
        """Read from the buffer from here on (arrays view it), with offsets in it."""
        if self.source == 'buf':
            return
        self.source = 'buf'
        if self.base:
            if self.static is not None:
                self.static += self.base
            else:
                self.src.add(f'pos += {self.base}')
            self.base = 0

    def fixed_arrays(self, arrays: list[tuple[int, FixArr]]) -> None:
        """Views of the fixed-size arrays of one run; three or more of one numeric type come
        from one ``frombuffer`` over their span (slicing an array costs half of making one)."""
        by_type: dict[str, list[tuple[int, FixArr]]] = {}
        for offset, array in arrays:
            by_type.setdefault(array.primitive, []).append((offset, array))
        for primitive, group in by_type.items():
            size = PRIMITIVE_SIZES[primitive]
            if len(group) < 3 or primitive == 'bool':
                for offset, array in group:
                    where = self.where(offset)
                    self.src.add(
                        f'{array.ref} = {self.array_expr(primitive, str(array.count), where)}'
                    )
                continue
            first = group[0][0]
            last_offset, last = group[-1]
            span = self.src.tmp('x')
            count = (last_offset - first) // size + last.count
            self.src.add(f'{span} = {self.array_expr(primitive, str(count), self.where(first))}')
            for offset, array in group:
                lo = (offset - first) // size
                part = self.src.ref(slice(lo, lo + array.count), 's')  # not built per call
                self.src.add(f'{array.ref} = {span}[{part}]')

    def array_expr(self, primitive: str, count: str, where: str) -> str:
        dtype = self.src.ref(numpy_dtype(primitive, self.endian), 'D')
        expr = f'{self.frombuffer}(buf, {dtype}, {count}, {where})'
        return f'({expr} != 0)' if primitive == 'bool' else expr

    def fail(self, condition: str, message: str) -> None:
        if self.trace:
            self.src.add(f'if {condition}: raise {self.bad}(f{message!r})')
        else:
            self.src.add(f'if {condition}: raise {self.bad}')

    def string(self, op: Str, start: int | None) -> State:
        """A string after its count: read at ``start`` where the offset is known when
        generating (the fast decoder's first string), else at ``pos``. ``e`` holds the offset
        of its NUL byte."""
        src = self.src
        at = 'pos' if start is None else str(start)
        with src.block(f'if {op.count}:'):
            src.add(
                f'e = pos - 1 + {op.count}' if start is None else f'e = {start - 1} + {op.count}'
            )
            if self.trace:  # the fast decoder's NUL check below raises IndexError then
                self.fail(
                    'e >= end',
                    f'string of {{{op.count} - 1}} bytes runs past the end of the buffer '
                    '({end} bytes)',
                )
            self.fail(f'{self.source}[e]', 'string does not end with a NUL byte')
            if self.trace:
                src.add(f"{op.ref} = str(buf[{at}:e], 'utf-8')")
            elif self.memory and self.source == 'buf':  # 40 ns faster than str(view, 'utf-8')
                src.add(f'{op.ref} = buf[{at}:e].tobytes().decode()')
            elif self.long_text is not None:
                mv = src.ref(memoryview, 'mv')
                with src.block(f'if {op.count} > {self.long_text}:'):
                    src.add(f"{op.ref} = str({mv}({self.source})[{at}:e], 'utf-8')")
                with src.block('else:'):
                    src.add(f'{op.ref} = {self.source}[{at}:e].decode()')
            else:
                src.add(f'{op.ref} = {self.source}[{at}:e].decode()')
            if op.bound:
                # the bound counts bytes (C++ readers check that), but rclpy checks characters
                # and writes longer strings: accept them when the characters fit
                self.fail(
                    f'{op.count} > {op.bound + 1} and len({op.ref}) > {op.bound}',
                    f'string of {{len({op.ref})}} characters exceeds its bound {op.bound}',
                )
            src.add('pos = e + 1')
        with src.block('else:'):
            src.add(f"{op.ref} = ''")
            if start is not None:
                src.add(f'pos = {start}')
        return UNKNOWN

    def emit_one(self, op: Op, state: State) -> State:
        src = self.src
        if isinstance(op, Fix):
            align = 1 if op.code in 'x?' else op.size
            state = self.align(state, align)
            self.mark(op.path)
            packer = src.ref(struct.Struct(self.endian + op.code), 'S')
            if op.ref is None:
                src.add(f'{packer}.unpack_from({self.source}, pos)')
            else:
                src.add(f'{op.ref}, = {packer}.unpack_from({self.source}, pos)')
            src.add(f'pos += {op.size}')
            return state.advance(op.size)
        if reads_buffer(op):  # an array, a wstring, or a loop of them: from the view on
            self.to_buffer()
        if isinstance(op, FixArr):
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
        if isinstance(op, Str) and not op.wide and self.static is not None:
            start, self.static = self.static, None
            return self.string(op, start)
        self.materialize()  # the operations below move the offset at run time
        if isinstance(op, Str):
            # the count before it was marked with this path: the offset stays at the field start
            if op.wide:
                decode = src.ref(convert.wstring_decode, 'wstr')
                if op.bound:
                    self.fail(
                        f'{op.count} > {op.bound}',
                        f'wstring of {{{op.count}}} characters exceeds its bound {op.bound}',
                    )
                src.add(
                    f'{op.ref}, pos = {decode}(buf, pos, {op.count}, {self.end}, {self.endian!r})'
                )
                return State(0, 4)
            return self.string(op, None)
        if isinstance(op, Seq):
            self.check_bound(op.count, op.bound)
            if op.struct:
                info = self.ctx.info(op.element)
                align, stride = info.first_align, info.size
                dtype = src.ref(self.ctx.dtype(op.element, self.endian), 'D')
                cls = src.ref(self.ctx.cls(op.element), 'C')
                make = src.ref(StructSeq._from_array, 'seq')
                empty = src.ref(convert.empty_array(self.ctx.dtype(op.element, self.endian)), 'E')
            else:
                align = stride = PRIMITIVE_SIZES[op.element]
                values = (
                    np.dtype('?') if op.element == 'bool' else numpy_dtype(op.element, self.endian)
                )
                empty = src.ref(convert.empty_array(values), 'E')
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
            after = State(0, min(align, 4)) if stride % min(align, 4) == 0 else UNKNOWN
            return merge_state(after, state)
        assert isinstance(op, Loop)
        entry = self.loops.entry(op, state)
        if self.src.trials:  # a dry run needs only the state after the loop
            return entry
        if op.count.isdigit():
            self.mark(op.path)
            self.read_elements(op, entry)
            return entry
        # a sequence: an empty one (MultiArrayLayout.dim, a marker's points) skips the list's
        # append method and the loop, which cost 100 ns
        with src.block(f'if {op.count}:'):
            self.check_bound(op.count, op.bound)
            left = f'{self.end} - {self.base} - pos' if self.base else f'{self.end} - pos'
            self.fail(
                f'{op.count} > ({left}) // {op.min_size}',
                f'{{{op.count}}} elements cannot fit in the {{end - pos}} bytes left',
            )
            self.read_elements(op, entry)
        with src.block('else:'):
            src.add(f'{op.ref} = []')
        return entry

    def check_bound(self, count: str, bound: int) -> None:
        """Refuse more than ``bound`` elements (a bounded sequence; -1: unbounded)."""
        if bound >= 0:
            self.fail(f'{count} > {bound}', f'{{{count}}} elements exceed the bound {bound}')

    def dry_emit(self, ops: list[Op], state: State) -> State:
        """The state ``emit(ops, state)`` would leave, emitting nothing."""
        source, base, static = self.source, self.base, self.static
        with self.src.trial():
            try:
                return self.emit(ops, state)
            finally:
                self.source, self.base, self.static = source, base, static

    def read_elements(self, op: Loop, entry: State) -> None:
        """The ``op.count`` elements of ``op``, each starting in state ``entry``, read into a
        new list."""
        src = self.src
        items = src.tmp('l')
        append = src.tmp('a')
        src.add(f'{items} = []; {append} = {items}.append')
        with src.block(f'for {op.index} in range({op.count}):'):
            self.emit(op.body, entry)
            src.add(f'{append}({op.item})')
        src.add(f'{op.ref} = {items}')
