"""Generate Python source for the codec and methods of one message class.

A message is flattened into a list of operations in wire order (``ops``): fixed-size reads or
writes, variable-size bodies (strings, sequences) and loops. Consecutive fixed-size operations,
across nested structs, merge into one ``struct`` call whenever their alignment is known
statically; the code tracks the body offset modulo 8 for that. Nested types are inlined, so
decoding a message is one function call.

Two flavours exist: the fast one, which raises the internal ``Bad`` (or any exception) on bad
input, and the *traced* one, which does one field at a time and turns any failure into a
:class:`~zros.cdr.errors.CdrError` naming the field and offset. The fast codec runs first; the
traced one only runs to explain a failure.

``decoder`` (from the operations ``decode_ops`` lists) and ``encoder`` generate the two
codecs, ``methods`` the class's ``__init__``, ``__eq__``, ``repr``, ``copy``, ``to_dict`` and
row helpers; ``program`` holds the source under construction and compiles it.
"""

from __future__ import annotations

from zros.cdr.codegen.decoder import generate_decoder
from zros.cdr.codegen.encoder import generate_encoder
from zros.cdr.codegen.methods import generate_methods
from zros.cdr.codegen.ops import Context
from zros.cdr.codegen.program import source_of

__all__ = [
    'Context',
    'generate_decoder',
    'generate_encoder',
    'generate_methods',
    'source_of',
]
