"""What users do with generated message classes."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

import zros
from zros import cdr
from zros.cdr import FieldError, StructSeq
from zros.cdr.registry import TypeRegistry, default_registry


@pytest.fixture
def registry() -> TypeRegistry:
    return TypeRegistry('jazzy', paths=[], ament=False)


def test_ros_defaults_constants_and_field_info(registry: TypeRegistry) -> None:
    registry.register_text(
        'demo_msgs/msg/Defaults',
        'uint8 LOW=1\nstring NAME="x"\n'
        'int32 count 7\nfloat64 gain 0.5\nbool on true\nstring label "hi"\n'
        'float32[3] xyz [1.0, 2.0, 3.0]\nint16[] seq [4, 5]\nstring[2] names ["a", "b"]\n'
        'uint8[4] raw\nfloat64 inf_default inf',
    )
    Defaults = registry.get_class('demo_msgs/msg/Defaults')
    d = Defaults()
    assert (d.count, d.gain, d.on, d.label, d.names) == (7, 0.5, True, 'hi', ['a', 'b'])
    assert d.xyz.dtype == np.float32 and d.xyz.tolist() == [1.0, 2.0, 3.0]
    assert d.seq.dtype == np.int16 and d.seq.tolist() == [4, 5]
    assert d.raw.dtype == np.uint8 and d.raw.tolist() == [0, 0, 0, 0]
    assert d.inf_default == float('inf')
    assert (Defaults.LOW, Defaults.NAME) == (1, 'x')
    assert Defaults.get_fields_and_field_types()['xyz'] == 'float32[3]'
    # every instance gets its own mutable defaults
    other = Defaults()
    other.xyz[0] = 9.0
    other.names.append('c')
    assert d.xyz[0] == 1.0 and d.names == ['a', 'b']


def test_construction_forms_and_conversions(registry: TypeRegistry) -> None:
    Pose = registry.get_class('geometry_msgs/msg/Pose')
    Point = registry.get_class('geometry_msgs/msg/Point')
    by_position = Point(1.0, 2.0, 3.0)
    assert Pose(position=by_position) == Pose(position={'x': 1.0, 'y': 2.0, 'z': 3.0})
    Imu = registry.get_class('sensor_msgs/msg/Imu')
    imu = Imu(orientation_covariance=[1, 2, 3, 4, 5, 6, 7, 8, 9])
    assert imu.orientation_covariance.dtype == np.float64
    with pytest.raises(
        ValueError, match="field 'orientation_covariance': expected exactly 9 elements, got 2"
    ):
        Imu(orientation_covariance=[1.0, 2.0])
    Image = registry.get_class('sensor_msgs/msg/Image')
    assert Image(data=b'\x01\x02').data.tolist() == [1, 2]
    with pytest.raises(ValueError, match="field 'data': value 300 is out of the range of uint8"):
        Image(data=[1, 300])
    with pytest.raises(TypeError, match="field 'data': expected integers, got float64 values"):
        Image(data=[1.5])
    with pytest.raises(TypeError):
        Point(x=1.0, w=2.0)  # no such field


def test_equality_repr_copy(registry: TypeRegistry) -> None:
    Image = registry.get_class('sensor_msgs/msg/Image')
    a = Image(height=2, data=[1, 2, 3])
    b = Image(height=2, data=np.array([1, 2, 3], np.uint8))
    assert a == b
    assert not a.__ne__(b)
    b.data = np.array([1, 2, 4], np.uint8)
    assert a != b
    assert a != 'not a message'
    assert (
        repr(registry.get_class('std_msgs/msg/String')(data='x')) == "std_msgs.msg.String(data='x')"
    )
    assert (
        'sensor_msgs.msg.Image(header=std_msgs.msg.Header(stamp=builtin_interfaces.msg.Time(sec=0'
        in repr(a)
    )
    decoded = cdr.decode(Image, cdr.encode(a))
    assert not decoded.data.flags.writeable  # a view into the bytes
    duplicate = decoded.copy()
    duplicate.data[0] = 42
    duplicate.header.frame_id = 'changed'
    assert decoded.data[0] == 1 and decoded.header.frame_id == ''
    assert copy.deepcopy(a) == a and copy.copy(a) == a
    with pytest.raises(TypeError):
        hash(a)


def test_dict_round_trip(registry: TypeRegistry) -> None:
    Odometry = registry.get_class('nav_msgs/msg/Odometry')
    odom = Odometry(child_frame_id='base')
    odom.pose.pose.position.x = 1.5
    odom.pose.covariance[0] = 0.25
    data = odom.to_dict()
    assert data['pose']['pose']['position']['x'] == 1.5
    assert data['pose']['covariance'][0] == 0.25 and isinstance(data['pose']['covariance'], list)
    assert Odometry.from_dict(data) == odom
    assert Odometry.from_dict({'child_frame_id': 'x'}).child_frame_id == 'x'
    with pytest.raises(
        ValueError,
        match=r"nav_msgs/msg/Odometry has no field 'childframe' \(did you mean 'child_frame_id'\?",
    ):
        Odometry.from_dict({'childframe': 'x'})
    with pytest.raises(TypeError, match='from_dict needs a mapping'):
        Odometry.from_dict(['x'])  # type: ignore[arg-type]
    Markers = registry.get_class('visualization_msgs/msg/MarkerArray')
    markers = Markers(markers=[{'ns': 'a', 'points': [{'x': 1.0}]}])
    assert markers.markers[0].points[0].x == 1.0
    assert Markers.from_dict(markers.to_dict()) == markers


def test_pickle_uses_the_default_registry() -> None:
    Twist = default_registry().get_class('geometry_msgs/msg/Twist')
    twist = Twist(linear={'x': 2.0})
    assert pickle.loads(pickle.dumps(twist)) == twist


def test_keyword_and_builtin_named_fields(registry: TypeRegistry) -> None:
    registry.register_text(
        'demo_msgs/msg/Words', 'int32 from\nstring type\nint32[] list\nint32 self'
    )
    Words = registry.get_class('demo_msgs/msg/Words')
    words = Words(from_=1, type='t', list=[1], self=3)
    assert Words._fields == ('from_', 'type', 'list', 'self')
    assert cdr.decode(Words, cdr.encode(words)) == words
    assert words.to_dict() == {'from': 1, 'type': 't', 'list': [1], 'self': 3}
    assert Words.from_dict({'from': 5}).from_ == 5


def test_decoded_arrays_are_views(registry: TypeRegistry) -> None:
    Image = registry.get_class('sensor_msgs/msg/Image')
    raw = bytearray(cdr.encode(Image(width=4, data=np.arange(4, dtype=np.uint8))))
    image = cdr.decode(Image, raw)
    assert np.shares_memory(image.data, np.frombuffer(raw, np.uint8))
    image.data[0] = 7  # writable when the buffer is
    assert raw[-4] == 7


def test_struct_sequences(registry: TypeRegistry) -> None:
    PoseArray = registry.get_class('geometry_msgs/msg/PoseArray')
    Pose = registry.get_class('geometry_msgs/msg/Pose')
    assert Pose._dtype is not None and Pose._dtype.itemsize == 56
    # build from objects, encode, decode into a zero-copy structured view
    poses = PoseArray(poses=[Pose(position={'x': float(i)}) for i in range(5)])
    assert isinstance(poses.poses, StructSeq) and len(poses.poses) == 5
    raw = bytearray(cdr.encode(poses))
    decoded = cdr.decode(PoseArray, raw)
    array = decoded.poses.array
    assert np.shares_memory(array, np.frombuffer(raw, np.uint8))
    assert array['position']['x'].tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert array['orientation']['w'].tolist() == [1.0] * 5
    assert decoded == poses
    # element access makes objects; changes to them are encoded
    decoded.poses[2].position.y = -1.0
    decoded.poses.append(Pose(position={'z': 9.0}))
    again = cdr.decode(PoseArray, cdr.encode(decoded))
    assert again.poses.array['position']['y'][2] == -1.0
    assert len(again.poses) == 6 and again.poses[5].position.z == 9.0
    # vectorised writes through .array are encoded too
    writable = again.copy()
    writable.poses.array['position']['x'] *= 10
    assert cdr.decode(PoseArray, cdr.encode(writable)).poses[4].position.x == 40.0
    # a structured array, or a StructSeq, can be assigned directly
    table = np.zeros(3, dtype=Pose._dtype)
    table['position']['z'] = [1, 2, 3]
    writable.poses = table
    assert cdr.decode(PoseArray, cdr.encode(writable)).poses[1].position.z == 2.0
    assert repr(cdr.decode(PoseArray, cdr.encode(PoseArray())).poses).startswith(
        'StructSeq(geometry_msgs/msg/Pose, array([]'
    )
    with pytest.raises(
        FieldError,
        match=r"PoseArray field 'poses\[0\]': expected a geometry_msgs/msg/Pose or a dict, got str",
    ):
        PoseArray(poses=['nope'])
    assigned = PoseArray()
    assigned.poses = ['nope']  # assignments are checked when the message is encoded
    with pytest.raises(
        cdr.CdrError, match="field 'poses': element 0: expected geometry_msgs/msg/Pose, got str"
    ):
        cdr.encode(assigned)
    with pytest.raises(TypeError, match='do not match'):
        decoded.poses.array = np.zeros(2, dtype=[('a', 'f8')])


def test_struct_sequence_of_small_structs(registry: TypeRegistry) -> None:
    Polygon = registry.get_class('geometry_msgs/msg/Polygon')
    Point32 = registry.get_class('geometry_msgs/msg/Point32')
    assert Point32._dtype.itemsize == 12
    polygon = Polygon(points=[Point32(1, 2, 3), Point32(4, 5, 6)])
    decoded = cdr.decode(Polygon, cdr.encode(polygon))
    assert decoded.points.array['y'].tolist() == [2.0, 5.0]
    assert [p.z for p in decoded.points] == [3.0, 6.0]
    assert decoded.points == [Point32(1, 2, 3), Point32(4, 5, 6)]


def test_empty_struct_sequences_decode_as_fresh_lists(registry: TypeRegistry) -> None:
    """An empty sequence of structs skips the decoding loop: each decode still gets a list of
    its own, and the fields after it are read from the right offset."""
    cls = registry.get_class('std_msgs/msg/UInt8MultiArray')
    data = cdr.encode(cls(layout={'data_offset': 7}, data=[1, 2, 3]))
    first, second = cdr.decode(cls, data), cdr.decode(cls, data)
    assert first.layout.dim == [] and first.layout.dim is not second.layout.dim
    first.layout.dim.append(registry.get_class('std_msgs/msg/MultiArrayDimension')(label='x'))
    assert second.layout.dim == [] and cdr.decode(cls, data).layout.dim == []
    assert first.layout.data_offset == 7 and list(first.data) == [1, 2, 3]
    assert cdr.decode(cls, cdr.encode(first)).layout.dim[0].label == 'x'


def test_same_type_from_two_registries_compares_by_content(registry: TypeRegistry) -> None:
    mine = registry.get_class('std_msgs/msg/String')(data='x')
    other = default_registry().get_class('std_msgs/msg/String')(data='x')
    assert type(mine) is not type(other)
    assert mine == other and other == mine
    assert mine != default_registry().get_class('std_msgs/msg/String')(data='y')
    assert mine != default_registry().get_class('std_msgs/msg/Char')()


def test_encoding_does_not_detach_element_objects(registry: TypeRegistry) -> None:
    PoseArray = registry.get_class('geometry_msgs/msg/PoseArray')
    Pose = registry.get_class('geometry_msgs/msg/Pose')
    pose = Pose()
    message = PoseArray(poses=[pose])
    cdr.encode(message)
    pose.position.x = 5.0  # the user keeps editing the object they put in
    assert cdr.decode(PoseArray, cdr.encode(message)).poses[0].position.x == 5.0


def test_encode_buffer_is_reused_and_byte_identical(registry: TypeRegistry) -> None:
    from zros.cdr.encode_buffer import EncodeBuffer

    Image = registry.get_class('sensor_msgs/msg/Image')
    Imu = registry.get_class('sensor_msgs/msg/Imu')
    buffer = EncodeBuffer(threshold=1000)
    small = Imu(header={'frame_id': 'imu'})
    assert type(small._cdr_encode(small, buffer.join)) is bytes  # under the threshold
    outputs = []
    for size in (5000, 3000, 8000, 8000):
        image = Image(width=size, data=np.arange(size, dtype=np.int64).astype(np.uint8))
        data = image._cdr_encode(image, buffer.join)
        assert bytes(data) == cdr.encode(image)
        outputs.append(data)
    assert outputs[2] is outputs[3]  # the same memory, reused
    floats = registry.get_class('std_msgs/msg/Float64MultiArray')(data=np.linspace(0, 1, 500))
    assert bytes(floats._cdr_encode(floats, buffer.join)) == cdr.encode(floats)


def test_unknown_fields_name_the_type_the_fields_and_the_closest(registry: TypeRegistry) -> None:
    with pytest.raises(
        FieldError,
        match=r"^std_msgs/msg/String has no field 'dat' \(did you mean 'data'\? fields: data\)$",
    ):
        zros.Message('std_msgs/msg/String', dat='x')
    PoseStamped = registry.get_class('geometry_msgs/msg/PoseStamped')
    nested = (
        "geometry_msgs/msg/PoseStamped has no field 'pose.position.xx' (did you mean "
        "'pose.position.x'? fields of geometry_msgs/msg/Point: x, y, z)"
    )
    for build in (
        lambda: PoseStamped(pose={'position': {'xx': 1.0}}),
        lambda: PoseStamped.from_dict({'pose': {'position': {'xx': 1.0}}}),
    ):
        with pytest.raises(FieldError) as caught:
            build()
        assert str(caught.value) == nested
        assert caught.value.field == 'pose.position.xx' and caught.value.closest == 'x'
    Markers = registry.get_class('visualization_msgs/msg/MarkerArray')
    with pytest.raises(FieldError, match=r"has no field 'markers\[1\]\.nss' \(did you mean"):
        Markers(markers=[{'ns': 'a'}, {'nss': 'b'}])
    with pytest.raises(FieldError, match=r"no field 'zzz' \(fields: header, poses\)"):
        registry.get_class('geometry_msgs/msg/PoseArray')(zzz=1)
    message = registry.get_class('std_msgs/msg/String')()
    with pytest.raises(AttributeError, match="'dat'"):
        message.dat = 'x'  # slots refuse unknown attributes


def test_constructor_checks_value_types(registry: TypeRegistry) -> None:
    def error(type_name: str, **fields: object) -> str:
        with pytest.raises(FieldError) as caught:
            registry.get_class(type_name)(**fields)
        return str(caught.value)

    assert error('std_msgs/msg/Float32', data='abc') == (
        "std_msgs/msg/Float32 field 'data': expected a float for float32, got str 'abc'"
    )
    assert error('std_msgs/msg/Float64', data=True).endswith('got bool True')
    assert error('std_msgs/msg/Int32', data=1.5) == (
        "std_msgs/msg/Int32 field 'data': expected an int for int32, got float 1.5"
    )
    assert error('std_msgs/msg/UInt8', data=np.int64(256)) == (
        "std_msgs/msg/UInt8 field 'data': 256 is out of the range of uint8 [0, 255]"
    )
    # a Python int out of range is caught when encoding (a range test per int field would cost
    # more at construction than the type test): the error names the field too
    with pytest.raises(cdr.CdrError, match="field 'data': 256 is out of the range of uint8"):
        cdr.encode(registry.get_class('std_msgs/msg/UInt8')(data=256))
    assert error('std_msgs/msg/Bool', data='false').endswith(
        "expected a bool (true or false), got str 'false'"
    )
    assert error('std_msgs/msg/String', data=5).endswith('expected a str for string, got int 5')
    assert error('std_msgs/msg/Header', stamp=3) == (
        "std_msgs/msg/Header field 'stamp': expected a builtin_interfaces/msg/Time or a dict, "
        'got int 3'
    )
    assert error('sensor_msgs/msg/Image', header={'stamp': {'sec': 'x'}}).startswith(
        "sensor_msgs/msg/Image field 'header.stamp.sec': expected an int for int32"
    )
    assert error('sensor_msgs/msg/JointState', name='joint1').endswith(
        "field 'name': expected a list of str, got str 'joint1'"
    )
    assert error('sensor_msgs/msg/JointState', name=['a', 2]).endswith(
        "field 'name[1]': expected a str for string, got int 2"
    )
    assert "field 'data': value 300 is out of the range of uint8" in error(
        'sensor_msgs/msg/Image', data=[1, 300]
    )
    long_repr = error('std_msgs/msg/Int8', data='x' * 200)
    assert len(long_repr) < 140 and long_repr.endswith('...')
    # what converts: ints to floats, numpy scalars to Python ones, 0 and 1 to bools
    Float32 = registry.get_class('std_msgs/msg/Float32')
    assert Float32(data=1).data == 1.0 and type(Float32(data=1).data) is float
    assert type(Float32(data=np.float32(0.5)).data) is float
    assert type(registry.get_class('std_msgs/msg/Int64')(data=np.int64(5)).data) is int
    assert registry.get_class('std_msgs/msg/Bool')(data=1).data is True
    assert registry.get_class('std_msgs/msg/Byte')(data=b'\x07').data == 7
    assert registry.get_class('std_msgs/msg/Char')(data='A').data == 65
    Point = registry.get_class('geometry_msgs/msg/Point')
    assert Point(1.0, 2.0, 3.0).z == 3.0  # positional arguments still work
    # the same type from another registry (a bag's own definitions) is accepted
    other = TypeRegistry('jazzy', paths=[], ament=False).get_class('geometry_msgs/msg/Point')
    assert registry.get_class('geometry_msgs/msg/Pose')(position=other(x=1.0)).position.x == 1.0


def test_definition_of_a_message_class_gives_its_fields_with_their_types(
    registry: TypeRegistry,
) -> None:
    registry.register_text('demo_msgs/msg/Pair', 'int32 count\nfloat64[3] xyz\nstring class')
    Pair = registry.get_class('demo_msgs/msg/Pair')
    definition = cdr.definition_of(Pair)
    assert definition.name == 'demo_msgs/msg/Pair'
    assert [f.name for f in definition.fields] == ['count', 'xyz', 'class']
    assert not definition.fields[1].type.is_scalar and definition.fields[0].type.is_scalar
    with pytest.raises(TypeError, match='not a message class'):
        cdr.definition_of(cdr.Message)


@pytest.mark.parametrize('name', ['Untyped', 'FieldValue'])
def test_the_aliases_of_any_are_deprecated_names_for_object(name: str) -> None:
    with pytest.warns(DeprecationWarning, match=rf'zros.cdr.{name} is deprecated: use object'):
        alias = getattr(cdr, name)
    assert alias is object
    assert name not in cdr.__all__
    with pytest.raises(AttributeError, match="has no attribute 'Unknown'"):
        _ = cdr.Unknown
