"""Parameters: a node's own (declared, validated, served to ROS tools) and other nodes'."""

from zros.params.client import ParameterClient, ParameterEvent, subscribe_parameter_events
from zros.params.descriptor import Descriptor, DescriptorFields, Parameter, SetResult
from zros.params.errors import (
    NodeNotFoundError,
    ParameterError,
    ParameterNotDeclaredError,
    ParameterTimeoutError,
)
from zros.params.files import dump, load_file, parse_file_text, parse_override, values_for
from zros.params.store import ParameterStore
from zros.params.values import ParameterType, ParamValue

__all__ = [
    'Descriptor',
    'DescriptorFields',
    'NodeNotFoundError',
    'ParamValue',
    'Parameter',
    'ParameterClient',
    'ParameterError',
    'ParameterEvent',
    'ParameterNotDeclaredError',
    'ParameterStore',
    'ParameterTimeoutError',
    'ParameterType',
    'SetResult',
    'dump',
    'load_file',
    'parse_file_text',
    'parse_override',
    'subscribe_parameter_events',
    'values_for',
]
