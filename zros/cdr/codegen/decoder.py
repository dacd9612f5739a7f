"""The generated CDR decoder of a message type (the fast one and the traced one)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import nullcontext
from typing import TYPE_CHECKING

from zros.cdr.codegen.decode_builder import HEAD_BYTES, DecoderBuilder, reads_buffer
from zros.cdr.codegen.decode_ops import DecodeOps
from zros.cdr.codegen.failures import decode_failure
from zros.cdr.codegen.ops import (
    START,
    Context,
    Fix,
    FixArr,
    Loop,
    Op,
    Pre,
    Seq,
    Str,
)
from zros.cdr.model import Buffer, MessageDef

if TYPE_CHECKING:
    from zros.cdr.message import Message

#: a memoryview of a message without arrays is copied to ``bytes`` whole (a copy costs less than
#: slices of the view, and no array of the result views it); a text longer than this many bytes
#: then decodes from a memoryview of the copy, which saves the slice's second copy
LONG_TEXT = 16384


def _all_ops(ops: list[Op]) -> Iterator[Op]:
    for op in ops:
        yield op
        if isinstance(op, Loop):
            yield from _all_ops(op.body)


def _head_reads(ops: list[Op]) -> tuple[bool, bool]:
    """Whether text is read before the first op that reads the buffer itself (a head copy
    pays), and whether text is read by index from the buffer after it."""
    head = later = False
    in_head = True
    for op in ops:
        if reads_buffer(op):
            in_head = False
        texts = any(isinstance(o, Str) and not o.wide for o in _all_ops([op]))
        if texts and in_head:
            head = True
        elif texts:
            later = True
    return head, later


def generate_decoder(
    ctx: Context,
    msg: MessageDef,
    endian: str,
    memory: bool,
    trace: bool,
    *,
    fallback: Callable[[Buffer, bool], Message] | None = None,
    memoryviews: bool = False,
) -> Callable[[Buffer, bool], Message]:
    """The function ``decode(buf, strict) -> message`` for the body after a valid header.

    It reads from offset 4 and ignores bytes left at the end, as DDS readers do (rclpy leaves
    up to 4 stray bytes per empty 8-byte sequence and per wstring). ``strict`` allows at most 3
    (any number with a wstring): bag readers check an embedded definition against its data so.
    A ``memory`` decoder reads a memoryview of bytes (format ``B``, one dimension).

    With a ``fallback`` it checks the header itself: it decodes the little-endian header
    ``00 01`` and hands the rest to ``fallback(buf, strict)``; data shorter than the header
    raises IndexError. A ``memory`` one takes memoryviews of any format then (the fallback gets
    those it cannot read). The other decodes ``bytes`` and ``bytearray``, and with
    ``memoryviews`` memoryviews too, in a second copy of its body: from the view, or for a type
    without arrays from a ``bytes`` copy of it; without, it hands them to the fallback.
    """
    builder = DecoderBuilder(ctx, endian, memory, trace)
    src = builder.src
    blank = src.blank(ctx.cls(msg.name))
    ops: list[Op] = []
    DecodeOps(ctx, src).struct_ops(msg, 'o', '', ops)
    wstring = ctx.info(msg.name).has_wstring
    if fallback is None:
        _emit_body(builder, ops, blank, wstring, msg.name)
        return src.compile('buf, strict=False', 'decode', msg.name)
    other = src.ref(fallback, 'other')
    flat = list(_all_ops(ops))
    first = next((op for op in flat if not isinstance(op, Pre)), None)
    # the first run of fixed fields reads the header too (struct reads bytes whatever the view's
    # format); else the code reads it by index, as it reads the NUL after a string
    by_run = isinstance(first, (Fix, FixArr))
    indexes = not by_run or any(isinstance(op, Str) and not op.wide for op in flat)
    views = any(isinstance(op, (FixArr, Seq)) for op in flat)

    def header_and_body(builder: DecoderBuilder) -> None:
        if by_run:
            builder.header_fallback = other
        else:
            src.add(
                f'if {builder.source}[1] != 1 or {builder.source}[0]: return {other}(buf, strict)'
            )
        _emit_body(builder, ops, blank, wstring, msg.name)

    def checked_body(builder: DecoderBuilder) -> None:
        if not (builder.memory and indexes):
            header_and_body(builder)
            return
        # text read by index from a view needs items of one byte: its other formats ('c'
        # reads b'\0', which is true) and shapes raise, and the fallback casts them. A check
        # of format and ndim would cost 50 ns per call; a try costs nothing
        head, later = _head_reads(ops) if views else (False, True)
        with src.block('try:'):
            if later or (not head and not by_run):
                src.add(f'if buf.itemsize != 1: return {other}(buf, strict)')
            if head and by_run:
                builder.head_pending = True
            elif head:
                src.add(f'hd = buf[:{HEAD_BYTES}].tobytes()')
                builder.source = 'hd'
            header_and_body(builder)
        with src.block('except Exception:'):
            src.add(f'return {other}(buf, strict)')

    if not memory and memoryviews:
        if indexes and not views:  # tobytes reads views of any format and shape
            with src.block('if type(buf) is memoryview:'):
                src.add('buf = buf.tobytes()')
                copied = DecoderBuilder(ctx, endian, False, False, src)
                copied.long_text = LONG_TEXT
                header_and_body(copied)
        else:  # the memoryview decoder inline: a call costs 120 ns
            with src.block('if type(buf) is memoryview:'):
                checked_body(DecoderBuilder(ctx, endian, True, False, src))
    elif not memory:
        src.add(f'if type(buf) is memoryview: return {other}(buf, strict)')
    checked_body(builder)
    return src.compile('buf, strict=False', 'decode', msg.name)


def _emit_body(
    builder: DecoderBuilder, ops: list[Op], blank: str, wstring: bool, type_name: str
) -> None:
    """The message's fields from ``ops``, the strict check of what is left, ``return o``."""
    src, trace = builder.src, builder.trace
    if trace:
        src.add('end = len(buf)')
        src.add('pos = 4')
        src.add("_f = '(header)'; _p = 0")
    explained = src.guarded(decode_failure, f'{type_name!r}, _f, _p, exc, end')
    with explained if trace else nullcontext():
        src.add(f'o = {blank}()')
        builder.emit(ops, START)
        if not wstring:
            if trace:
                src.add("_f = ''; _p = pos")
            left = (
                f'{builder.end} > {builder.static + 3}'
                if builder.static is not None
                else f'{builder.end} - pos > 3'
            )
            builder.fail(
                f'strict and {left}',
                '{end - pos} bytes left after the end of the message (at most 3 padding bytes '
                'are allowed); the data may be of another type or version',
            )
        src.add('return o')
