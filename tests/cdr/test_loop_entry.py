"""What the code generators know about the offset at the start of a loop's elements."""

from __future__ import annotations

from zros.cdr.codegen.ops import START, UNKNOWN, State, loop_entry


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
