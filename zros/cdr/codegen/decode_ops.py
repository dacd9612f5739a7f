"""The operations that decode a message: its fields in wire order, nested types inlined (what
:mod:`zros.cdr.codegen.decoder` turns into code)."""

from __future__ import annotations

from zros.cdr.codegen.ops import (
    STRUCT_CODES,
    Context,
    Fix,
    FixArr,
    Loop,
    Op,
    Pre,
    Seq,
    Str,
    empty_message,
    fields_of,
)
from zros.cdr.codegen.program import Program
from zros.cdr.model import PRIMITIVE_SIZES, FieldType, Kind, MessageDef


class DecodeOps:
    """Builds the decoder's operations; ``src`` gives the names of their temporaries."""

    def __init__(self, ctx: Context, src: Program) -> None:
        self.ctx = ctx
        self.src = src

    def struct_ops(self, msg: MessageDef, var: str, path: str, ops: list[Op]) -> None:
        if not msg.fields:
            ops.append(empty_message(path))
            return
        for ref, fpath, t in fields_of(msg, var, path):
            if t.kind is Kind.SCALAR:
                self.scalar_ops(t, ref, fpath, ops)
            elif t.kind is Kind.ARRAY:
                if t.is_primitive:
                    ops.append(FixArr(t.base, t.length, ref, fpath))
                else:
                    ops.append(self.loop(t, str(t.length), -1, ref, fpath))
            else:
                count = self.src.tmp('n')
                ops.append(Fix('I', 4, count, fpath))
                bound = t.length if t.kind is Kind.BOUNDED else -1
                if t.is_primitive:
                    ops.append(Seq(t.base, ref, count, bound, fpath, False))
                elif t.is_nested and self.ctx.info(t.base).uniform:
                    ops.append(Seq(t.base, ref, count, bound, fpath, True))
                else:
                    ops.append(self.loop(t, count, bound, ref, fpath))

    def scalar_ops(self, t: FieldType, ref: str, path: str, ops: list[Op]) -> None:
        if t.is_primitive:
            ops.append(Fix(STRUCT_CODES[t.base], PRIMITIVE_SIZES[t.base], ref, path, t.base))
        elif t.is_string:
            count = self.src.tmp('n')
            ops.append(Fix('I', 4, count, path))
            ops.append(Str(ref, count, t.string_bound, path, t.base == 'wstring'))
        else:
            var = self.src.tmp('v')
            blank = self.src.blank(self.ctx.cls(t.base))
            ops.append(Pre([f'{var} = {blank}()', f'{ref} = {var}']))
            self.struct_ops(self.ctx.resolve(t.base), var, path, ops)

    def loop(self, t: FieldType, count: str, bound: int, ref: str, path: str) -> Loop:
        index = self.src.tmp('i')
        item = self.src.tmp('e')
        body: list[Op] = []
        self.scalar_ops(t.element, item, f'{path}[{{{index}}}]', body)
        min_size = 4 if t.is_string else self.ctx.info(t.base).min_size
        return Loop(count, bound, min_size, ref, item, index, body, path)
