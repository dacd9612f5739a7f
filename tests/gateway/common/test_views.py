"""The graph views both gateways show: services offered, nodes serving parameters, owners."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from zros.gateway.common.views import (
    endpoint_owner,
    offered_services,
    parameter_nodes,
    service_providers,
)

Make = Callable[..., Any]
TIMEOUT = 10.0


def test_graph_views(zros_node: Make) -> None:
    server = zros_node('adder', start_parameter_services=True)
    server.create_service('example_interfaces/srv/AddTwoInts', '/add_two_ints')
    server.create_service('std_srvs/srv/Empty', '/_hidden')
    observer = zros_node('observer', start_parameter_services=False)
    # the parameter services are declared after /add_two_ints's node, each in a token of its own
    assert observer.graph.wait_until(
        lambda: (
            parameter_nodes(offered_services(observer)) == ['/adder']
            and '/add_two_ints' in offered_services(observer)
            and '/_hidden' in offered_services(observer, include_hidden=True)
        ),
        TIMEOUT,
    )
    services = offered_services(observer)
    assert services['/add_two_ints'] == 'example_interfaces/srv/AddTwoInts'
    assert '/_hidden' not in services
    assert '/_hidden' in offered_services(observer, include_hidden=True)
    # which node owns an endpoint arrives in a token of its own, just after the endpoint's
    assert observer.graph.wait_until(
        lambda: '/add_two_ints' not in offered_services(observer, exclude_node='/adder'), TIMEOUT
    )
    assert parameter_nodes(services) == ['/adder']
    assert parameter_nodes({'/x/get_parameters': 'rcl_interfaces/srv/GetParameters'}) == []
    (endpoint,) = [
        e
        for e in observer.graph.endpoints()
        if e.ros_name(observer.scheme.namespace) == '/add_two_ints'
    ]
    assert endpoint_owner(endpoint, observer.graph) == '/adder'
    assert service_providers(observer, ['/add_two_ints', '/nothing']) == {
        '/add_two_ints': ['/adder']
    }
