"""Name filters: regexes as foxglove_bridge's whitelists, globs as rosbridge's."""

from __future__ import annotations

import pytest

from zros.gateway.common.errors import GatewayError
from zros.gateway.common.filters import NameFilter


def test_regex_filters_match_whole_names() -> None:
    everything = NameFilter.regexes()
    assert everything('/anything')
    chosen = NameFilter.regexes(['/camera/.*', '/tf'], ['.*/compressed'])
    assert chosen('/camera/image') and chosen('/tf')
    assert not chosen('/tf_static')  # a whole-name match, as foxglove_bridge's whitelists
    assert not chosen('/camera/image/compressed')
    assert not chosen('/odom')
    with pytest.raises(GatewayError, match=r"'\[' is not a valid regex"):
        NameFilter.regexes(['['])


def test_glob_filters() -> None:
    chosen = NameFilter.globs(['/camera/*', '/tf'], ['*/compressed'])
    assert chosen('/camera/image') and chosen('/tf')
    assert not chosen('/camera/image/compressed') and not chosen('/tf_static')
    assert 'include' in repr(chosen)
