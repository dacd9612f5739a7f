"""The base class of generated message classes, and the encode and decode entry points.

Every ROS message type becomes a subclass of :class:`Message` with ``__slots__``, ROS default
values, ``==``, a readable ``repr``, ``copy``, ``to_dict``/``from_dict`` and its CDR codec
(``zros.cdr.classes`` builds them; the codec is generated on first use).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, ClassVar, Protocol, TypeVar

from zros.cdr.arrays import DType
from zros.cdr.encode_buffer import Join
from zros.cdr.errors import CdrError, FieldError
from zros.cdr.model import Buffer, MessageDef
from zros.cdr.naming import attribute_name

if TYPE_CHECKING:
    import typing_extensions
    from typing_extensions import Self

    #: a message class; a ``Publisher`` written without one is a ``Publisher[Message]``
    M = typing_extensions.TypeVar('M', bound='Message', default='Message')
else:  # TypeVar's default= is Python 3.13's
    M = TypeVar('M', bound='Message')


class TracedCodecs(Protocol):
    """The slow codecs of a class that name the field and offset of a failure."""

    def traced_encoder(self) -> Callable[[Message], bytes]:
        """The encoder that raises a CdrError naming the field that cannot be encoded."""
        ...

    def traced_decoder(self, endian: str) -> Callable[[memoryview, bool], Message]:
        """The decoder (``'<'`` or ``'>'``) that raises a CdrError naming field and offset."""
        ...


class Message:
    """Base class of all generated message classes."""

    __slots__ = ()
    __hash__ = None  # type: ignore[assignment]  # messages are mutable

    __msgtype__: ClassVar[str]
    #: attribute names, in field order
    _fields: ClassVar[tuple[str, ...]] = ()
    #: attribute name -> field type as written in .msg files
    _field_types: ClassVar[dict[str, str]] = {}
    _definition: ClassVar[MessageDef]
    #: the TypeRegistry that built the class. The registry module sits above this one, so the
    #: type is not named here; ``zros.cdr.registry.registry_of(cls)`` returns it typed.
    _registry: ClassVar[object]
    #: numpy dtype of one element when a sequence of this type is a structured array, else None
    _dtype: ClassVar[DType | None] = None
    _zros_codecs: ClassVar[TracedCodecs]
    #: rebuilds a message from its type name and CDR bytes when unpickling (set per class)
    _restore: ClassVar[Callable[[str, bytes], Message]]

    if TYPE_CHECKING:
        # Fields are generated at run time. A field read on this untyped base is Any on purpose,
        # as rclpy's untyped messages: `0.2 / msg.data` type-checks in a user's program, and a
        # program that wants checked fields declares its class (see tests/test_typing.py).
        def __getattr__(self, name: str) -> Any: ...  # type: ignore[explicit-any,unused-ignore]  # as above

        def __setattr__(self, name: str, value: object) -> None: ...

    # generated per class
    def __init__(self, *args: object, **kwargs: object) -> None:
        raise TypeError('Message is abstract; use zros.Message(type) or a generated class')

    def copy(self) -> Self:
        """A deep copy; its arrays are writable even where this message's are views."""
        raise NotImplementedError

    def to_dict(self) -> dict[str, object]:
        """Nested dicts and lists of plain Python values (YAML and JSON friendly)."""
        raise NotImplementedError

    @staticmethod
    def _cdr_encode(message: Message, join: Join | None = None) -> bytes:
        raise NotImplementedError

    @staticmethod
    def _cdr_decode(buf: Buffer, strict: bool = False) -> Message:
        raise NotImplementedError

    # common API

    @classmethod
    def from_dict(cls, data: Mapping[str, object]) -> Self:
        """Build a message from nested dicts, as ``to_dict`` returns them.

        Missing fields keep their defaults. Keys may be ROS names or attribute names (``from`` or
        ``from_``). An unknown key, or a value its field cannot hold, raises a
        :class:`~zros.cdr.errors.FieldError` naming the field's path.
        """
        if not isinstance(data, Mapping):
            raise TypeError(
                f'{cls.__msgtype__}.from_dict needs a mapping, got {type(data).__name__}'
            )
        names = {f.name: attribute_name(f.name) for f in cls._definition.fields}
        attributes = set(names.values())
        for key in data:
            if key not in names and key not in attributes:
                raise FieldError.unknown(cls.__msgtype__, str(key), tuple(names))
        return cls(**{names.get(key, key): value for key, value in data.items()})

    def serialize(self) -> bytes:
        """CDR bytes of this message (little-endian, with the 4-byte header)."""
        return encode(self)

    @classmethod
    def deserialize(cls, buf: bytes | bytearray | memoryview, strict: bool = False) -> Self:
        """Decode CDR bytes (header included) into a message of this type."""
        return decode(cls, buf, strict)

    @classmethod
    def get_fields_and_field_types(cls) -> dict[str, str]:
        """Field names and their ROS types, as rclpy messages offer them."""
        return dict(cls._field_types)

    def __copy__(self) -> Self:
        return self.copy()

    def __deepcopy__(self, memo: dict[int, object]) -> Self:
        return self.copy()

    def __reduce__(self) -> tuple[Callable[[str, bytes], Message], tuple[str, bytes]]:
        return (type(self)._restore, (self.__msgtype__, encode(self)))


# --- encode / decode entry points -----------------------------------------------------------


def definition_of(cls: type[Message]) -> MessageDef:
    """The parsed definition of a message class: its type name and its fields in order, each
    with its name and :class:`~zros.cdr.model.FieldType` (TypeError for anything else)."""
    definition = getattr(cls, '_definition', None) if isinstance(cls, type) else None
    if not isinstance(definition, MessageDef):
        raise TypeError(f'{cls!r} is not a message class built by a TypeRegistry')
    return definition


def encode(message: Message) -> bytes:
    """CDR bytes of a message: the 4-byte little-endian header, then the body, no padding."""
    try:
        return message._cdr_encode(message)
    except Exception as exc:
        raise encode_failure(message, exc) from None


def decode(cls: type[M], buf: bytes | bytearray | memoryview, strict: bool = False) -> M:
    """Decode CDR bytes (header included) into a message of class ``cls``.

    Arrays of the result are views into ``buf`` (read-only when ``buf`` is ``bytes``). Bytes
    after the message are ignored, as DDS readers ignore them; ``strict=True`` allows at most 3
    (alignment padding), which tells whether the data really is of this type.
    """
    try:
        return cls._cdr_decode(buf, strict)  # type: ignore[return-value]  # the class decodes its own type
    except Exception as exc:
        raise decode_failure(cls, buf, strict, exc) from None


# --- the one fallback of the fast codecs: each caller tries the fast (generated) encoder or
# decoder inline, where a try costs nothing, and on failure raises what these return


def encode_failure(message: object, exc: Exception) -> Exception:
    """What encoding ``message`` raises once its fast encoder raised ``exc``: ``exc`` itself
    when a CdrError, else the traced encoder's CdrError, which names the field."""
    if isinstance(exc, CdrError):
        return exc
    if not isinstance(message, Message):
        return TypeError(f'expected a zros message, got {type(message).__name__}')
    return _explain_encode(type(message), message)


def decode_failure(cls: type[Message], buf: Buffer, strict: bool, exc: Exception) -> Exception:
    """What decoding ``buf`` as ``cls`` raises once the fast decoder raised ``exc``: ``exc``
    itself when a CdrError, else the traced decoder's CdrError (field and offset)."""
    if isinstance(exc, CdrError):
        return exc
    return _explain_decode(cls, buf, strict)


def _codecs(cls: type[Message]) -> TracedCodecs:
    codecs: TracedCodecs = cls.__dict__['_zros_codecs']
    return codecs


def _explain_encode(cls: type[Message], message: Message) -> CdrError:
    traced = _codecs(cls).traced_encoder()
    try:
        traced(message)
    except CdrError as exc:
        return exc
    return CdrError(f'cannot encode {cls.__msgtype__}', type_name=cls.__msgtype__)


def _explain_decode(cls: type[Message], buf: Buffer, strict: bool) -> CdrError:
    name = getattr(cls, '__msgtype__', '?')
    try:
        view = memoryview(buf)
    except TypeError:
        return CdrError(
            f'cannot decode {name}: expected bytes, bytearray or memoryview, '
            f'got {type(buf).__name__}',
            type_name=name,
        )
    if view.ndim != 1 or view.itemsize != 1:
        view = view.cast('B')
    size = len(view)
    if size < 4:
        return CdrError(
            f'cannot decode {name}: {size} bytes is shorter than the 4-byte CDR header',
            type_name=name,
            offset=0,
        )
    if view[0] != 0 or view[1] > 1:
        return CdrError(
            f'cannot decode {name}: unsupported encapsulation {bytes(view[:2]).hex()} '
            '(only plain CDR, 0000 big-endian or 0001 little-endian, is supported)',
            type_name=name,
            offset=0,
        )
    traced = _codecs(cls).traced_decoder('<' if view[1] else '>')
    try:
        traced(view, strict)
    except CdrError as exc:
        return exc
    return CdrError(f'cannot decode {name}', type_name=name)
