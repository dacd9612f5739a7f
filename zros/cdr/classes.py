"""Building the class of a message type: its generated methods and lazily compiled codecs.

The registry calls :func:`build_message_class` once per type and caches the class; what the
builder needs from the registry is the small :class:`ClassSource` interface, so this module
never imports the registry.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import Protocol

from zros.cdr import codegen
from zros.cdr.arrays import DType
from zros.cdr.codegen.encoder import Encoder
from zros.cdr.convert import Bad
from zros.cdr.encode_buffer import Join
from zros.cdr.layout import LayoutCache, StructInfo
from zros.cdr.message import Message
from zros.cdr.model import Buffer, MessageDef
from zros.cdr.naming import attribute_name

#: a compiled decoder: ``decode(buf, strict) -> message``
Decoder = Callable[[Buffer, bool], Message]


class ClassSource(Protocol):
    """What building a class needs from the registry that owns it."""

    @property
    def layout(self) -> LayoutCache:
        """The layout facts of the registry's types."""
        ...

    @property
    def lock(self) -> AbstractContextManager[bool]:
        """The re-entrant lock that guards the registry (codecs compile under it)."""
        ...

    def message_definition(self, name: str) -> MessageDef:
        """The definition of a message type."""
        ...

    def get_class(self, name: str) -> type[Message]:
        """The class of a message type."""
        ...


class _Codecs:
    """Compiles the codec variants of one class on first use; the generators' context."""

    def __init__(self, source: ClassSource, cls: type[Message]) -> None:
        self.source = source
        self.message_class = cls
        self._traced_decoders: dict[str, Decoder] = {}
        self._traced_encoder: Encoder | None = None

    # the generators' Context
    def resolve(self, name: str) -> MessageDef:
        return self.source.message_definition(name)

    def info(self, name: str) -> StructInfo:
        return self.source.layout.info(name)

    def cls(self, name: str) -> type:
        # the class being built is not in the registry yet
        if name == self.message_class.__msgtype__:
            return self.message_class
        return self.source.get_class(name)

    def dtype(self, name: str, endian: str) -> DType:
        return self.source.layout.dtype(name, endian)

    # the variants
    def entry_decoder(self) -> Decoder:
        """The class's ``_cdr_decode``: compiled on the first call (under the registry's lock)."""
        cls = self.message_class
        current: Decoder = cls.__dict__['_cdr_decode']
        if getattr(current, '__zros_entry__', False):
            return current
        variants: dict[str, Decoder] = {}

        def other(view: Buffer, strict: bool) -> Message:
            # big-endian data, or a memoryview of another format: compile on demand
            if type(view) is memoryview and (view.format != 'B' or view.ndim != 1):
                view = view.cast('B')
            if len(view) < 4 or view[0] or view[1] > 1:
                raise Bad
            key = ('m' if type(view) is memoryview else 'b') + ('<' if view[1] else '>')
            if key not in variants:
                with self.source.lock:
                    variants[key] = self.decoder(key[1], key[0] == 'm')
            return variants[key](view, strict)

        definition = cls._definition
        entry = codegen.generate_decoder(
            self, definition, '<', False, False, fallback=other, memoryviews=True
        )
        entry.__zros_entry__ = True  # type: ignore[attr-defined]  # a marker on the function
        cls._cdr_decode = entry  # type: ignore[method-assign,assignment]  # the compiled decoder replaces the stub
        return entry

    def decoder(self, endian: str, memory: bool) -> Decoder:
        definition = self.message_class._definition
        return codegen.generate_decoder(self, definition, endian, memory, False)

    def encoder(self) -> Encoder:
        return codegen.generate_encoder(self, self.message_class._definition, False)

    def traced_decoder(self, endian: str) -> Decoder:
        key = 'd' + endian
        if key not in self._traced_decoders:
            definition = self.message_class._definition
            decoder = codegen.generate_decoder(self, definition, endian, True, True)
            self._traced_decoders[key] = decoder
        return self._traced_decoders[key]

    def traced_encoder(self) -> Encoder:
        if self._traced_encoder is None:
            definition = self.message_class._definition
            self._traced_encoder = codegen.generate_encoder(self, definition, True)
        return self._traced_encoder


def _install_lazy_codecs(cls: type[Message], codecs: _Codecs) -> None:
    """Give ``cls`` codec stubs that compile the real functions on their first call."""
    lock = codecs.source.lock

    def decode_first(buf: Buffer, strict: bool = False) -> Message:
        compiled_decoder(cls)
        return cls._cdr_decode(buf, strict)

    def encode_first(message: Message, join: Join = b''.join) -> bytes:  # type: ignore[assignment]  # join may be an EncodeBuffer.join
        with lock:
            if cls.__dict__['_cdr_encode'] is lazy_encode:
                cls._cdr_encode = staticmethod(codecs.encoder())  # type: ignore[method-assign,assignment]  # the stub is replaced by the compiled encoder
        return cls._cdr_encode(message, join)

    lazy_encode = staticmethod(encode_first)
    # a plain function, not a staticmethod: Python specialises calls of a function found on a
    # class (``cls._cdr_decode(...)``), not of a staticmethod; it is never read from instances
    cls._cdr_decode = decode_first  # type: ignore[method-assign]  # a stub, compiled on first call
    cls._cdr_encode = lazy_encode  # type: ignore[method-assign,assignment]  # as above


def compiled_decoder(cls: type[Message]) -> Decoder:
    """The decoder of a class (``decode(buf, strict) -> message``), compiled if not yet.

    It decodes ``bytes`` with the little-endian header itself and hands anything else (big
    endian, a ``memoryview``) to variants it compiles on demand. Bad input raises any exception:
    :func:`zros.cdr.message.decode` turns those into a CdrError that names the field.
    """
    codecs: _Codecs = cls.__dict__['_zros_codecs']
    with codecs.source.lock:
        return codecs.entry_decoder()


def build_message_class(
    source: ClassSource,
    definition: MessageDef,
    restore: Callable[[str, bytes], Message],
) -> type[Message]:
    """Create the class of one message type (called by the registry, which caches it).

    ``restore(type_name, data)`` rebuilds a message when unpickling: a module-level function,
    so pickle can name it.
    """
    package, kind, short = definition.name.split('/')
    attributes = tuple(attribute_name(f.name) for f in definition.fields)
    namespace: dict[str, object] = {
        '__slots__': attributes,
        '__module__': f'zros.types.{package}.{kind}',
        '__qualname__': short,
        '__msgtype__': definition.name,
        '_fields': attributes,
        '_field_types': {attribute_name(f.name): str(f.type) for f in definition.fields},
        '_definition': definition,
        '_registry': source,
        '_restore': staticmethod(restore),
        '__annotations__': {attribute_name(f.name): str(f.type) for f in definition.fields},
    }
    for constant in definition.constants:
        namespace[constant.name] = constant.value
    cls: type[Message] = type(short, (Message,), namespace)
    codecs = _Codecs(source, cls)
    cls._zros_codecs = codecs
    for name, function in codegen.generate_methods(codecs, definition).items():
        setattr(cls, name, function)
    if source.layout.info(definition.name).uniform:
        cls._dtype = source.layout.dtype(definition.name, '<')
    _install_lazy_codecs(cls, codecs)
    return cls


__all__ = ['ClassSource', 'build_message_class', 'compiled_decoder']
