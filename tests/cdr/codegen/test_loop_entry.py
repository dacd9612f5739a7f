"""What the code generators know about the offset at the start of a loop's elements, and how
they cope with loops nested deep."""

from __future__ import annotations

from contextlib import AbstractContextManager

import pytest

from zros.cdr import CdrError, decode, encode
from zros.cdr.codegen.ops import START, UNKNOWN, State, loop_entry
from zros.cdr.codegen.program import Program
from zros.cdr.message import Message
from zros.cdr.registry import TypeRegistry


def test_an_element_that_ends_aligned_keeps_its_start_known() -> None:
    # a TransformStamped: it starts aligned to 4 and ends after float64s aligned to 8
    after_count = State(4, 8)
    assert loop_entry(after_count, lambda state: State(0, 8)) == State(0, 4)


def test_an_element_that_ends_anywhere_leaves_nothing_known() -> None:
    assert loop_entry(START, lambda state: UNKNOWN) == UNKNOWN


def test_an_element_of_fixed_size_keeps_what_it_started_with() -> None:
    assert loop_entry(START, lambda state: state.advance(16)) == START


def test_an_answer_that_does_not_settle_gives_up_knowing() -> None:
    # an element whose end depends on its start so that the answer keeps flipping
    def flipping(state: State) -> State:
        return State(4, 8) if state.modulus == 8 else START

    assert loop_entry(START, flipping) == UNKNOWN


def _nested(registry: TypeRegistry, depth: int) -> type[Message]:
    """``deep_msgs/L0``: a string and a sequence of ``L1``, and so on ``depth`` levels down."""
    for level in range(depth, -1, -1):
        inner = f'\ndeep_msgs/L{level + 1}[] items' if level < depth else ''
        registry.register_text(f'deep_msgs/msg/L{level}', 'string name' + inner)
    return registry.get_class('deep_msgs/msg/L0')


def _chain(registry: TypeRegistry, depth: int) -> Message:
    """An ``L0`` holding one ``L1``, and so on down to one ``L{depth}``."""
    message = registry.get_class(f'deep_msgs/msg/L{depth}')(name='y')
    for level in range(depth - 1, -1, -1):
        message = registry.get_class(f'deep_msgs/msg/L{level}')(name='x', items=[message])
    return message


def test_nested_loops_are_dry_run_once_per_entry_state(monkeypatch: pytest.MonkeyPatch) -> None:
    # each loop's entry state is found once; found anew, the dry runs of nested loops multiply
    # (3 ** depth: generating this type's codecs would not end in any reasonable time)
    trials = 0
    real = Program.trial

    def counted(self: Program) -> AbstractContextManager[None]:
        nonlocal trials
        trials += 1
        assert trials < 1000, 'dry runs multiply with the nesting depth'
        return real(self)

    monkeypatch.setattr(Program, 'trial', counted)
    registry = TypeRegistry('jazzy', paths=[], ament=False)
    cls = _nested(registry, 16)
    message = _chain(registry, 16)
    assert decode(cls, encode(message)) == message
    assert 0 < trials < 1000


def test_a_type_nested_deeper_than_python_allows_is_refused_clearly() -> None:
    cls = _nested(TypeRegistry('jazzy', paths=[], ament=False), 30)
    with pytest.raises(CdrError, match=r'deep_msgs/msg/L0.*nests its fields too deeply'):
        encode(cls(name='x'))
    header_and_empty = bytes([0, 1, 0, 0, 2, 0, 0, 0, ord('x'), 0, 0, 0, 0, 0, 0, 0])
    with pytest.raises(CdrError, match='decode function of deep_msgs/msg/L0'):
        decode(cls, header_and_empty)
