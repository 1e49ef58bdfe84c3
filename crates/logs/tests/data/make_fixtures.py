"""Writes the small fixtures tests/ros/interop.rs reads: ROS 1 bags written by the Python
`rosbags` package (uncompressed, bz2, lz4) and MCAP files written by the `mcap` and
`mcap-ros2-support` packages (zstd, lz4, uncompressed): other implementations than ours.
Run from the crate root: pip install rosbags mcap mcap-ros2-support; python3 tests/data/make_fixtures.py
Then a ROS 2 SQLite bag folder (`py-rosbag2/`) with the MCAP files' /cmd messages, and the bags'
/imu converted to MCAP as `mcap convert` does (`py-ros1.mcap`: `ros1msg` schema, ROS 1 messages).
Message i has header.stamp = 1700000000 + i // 100 + (i % 100) * 0.01 s; the bags' /imu has
header.seq = i and angular_velocity.x = 0.5 i; the MCAP files' /cmd has twist.linear.x = 0.25 i
and twist.angular.z = -0.5 i.
"""
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore
import numpy as np
ts = get_typestore(Stores.ROS1_NOETIC)
Imu = ts.types['sensor_msgs/msg/Imu']; Header = ts.types['std_msgs/msg/Header']; Time = ts.types['builtin_interfaces/msg/Time']
Q = ts.types['geometry_msgs/msg/Quaternion']; V = ts.types['geometry_msgs/msg/Vector3']
for comp in [None, Writer.CompressionFormat.BZ2, Writer.CompressionFormat.LZ4]:
    name = f"tests/data/py-{comp.name.lower() if comp else 'none'}.bag"
    import os
    if os.path.exists(name): os.remove(name)
    w = Writer(name)
    if comp: w.set_compression(comp)
    with w:
        c = w.add_connection('/imu', Imu.__msgtype__, typestore=ts)
        for i in range(300):
            m = Imu(Header(i, Time(1700000000 + i//100, (i%100)*10_000_000), 'imu'), Q(0,0,0,1), np.zeros(9), V(i*0.5,0,0), np.zeros(9), V(0,0,-9.81), np.zeros(9))
            w.write(c, (1700000000 + i//100)*10**9 + (i%100)*10_000_000 + 5, ts.serialize_ros1(m, Imu.__msgtype__))
from mcap_ros2.writer import Writer as McapWriter
for comp in ['zstd', 'lz4', 'none']:
    from mcap.writer import CompressionType
    with open(f'tests/data/py-{comp}.mcap', 'wb') as f:
        w = McapWriter(f, compression={'zstd': CompressionType.ZSTD, 'lz4': CompressionType.LZ4, 'none': CompressionType.NONE}[comp])
        schema = w.register_msgdef('geometry_msgs/msg/TwistStamped', 'std_msgs/Header header\nTwist twist\n================================================================================\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n================================================================================\nMSG: geometry_msgs/Twist\nVector3 linear\nVector3 angular\n================================================================================\nMSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z')
        for i in range(300):
            w.write_message('/cmd', schema, {'header': {'stamp': {'sec': 1700000000 + i//100, 'nanosec': (i%100)*10_000_000}, 'frame_id': 'base'}, 'twist': {'linear': {'x': i*0.25, 'y': 0, 'z': 0}, 'angular': {'x': 0, 'y': 0, 'z': -i*0.5}}}, log_time=1700000000*10**9 + i*10_000_000 + 7, publish_time=0)
        w.finish()
# A ROS 2 SQLite bag (a rosbag2 folder: metadata.yaml and its .db3), written by `rosbags`'
# rosbag2 writer with the same /cmd messages as the MCAP files.
import shutil
from rosbags.rosbag2 import Writer as Bag2Writer, StoragePlugin
ts2 = get_typestore(Stores.ROS2_HUMBLE)
TS = ts2.types['geometry_msgs/msg/TwistStamped']; H2 = ts2.types['std_msgs/msg/Header']; T2 = ts2.types['builtin_interfaces/msg/Time']
Tw = ts2.types['geometry_msgs/msg/Twist']; V2 = ts2.types['geometry_msgs/msg/Vector3']
shutil.rmtree('tests/data/py-rosbag2', ignore_errors=True)
with Bag2Writer('tests/data/py-rosbag2', version=8, storage_plugin=StoragePlugin.SQLITE3) as w:
    c = w.add_connection('/cmd', TS.__msgtype__, typestore=ts2)
    for i in range(300):
        m = TS(H2(T2(1700000000 + i//100, (i%100)*10_000_000), 'base'), Tw(V2(i*0.25, 0, 0), V2(0, 0, -i*0.5)))
        w.write(c, 1700000000*10**9 + i*10_000_000 + 7, ts2.serialize_cdr(m, TS.__msgtype__))
# A ROS 1 bag's /imu as `mcap convert` writes it: profile `ros1`, a `ros1msg` schema (the
# bag's message_definition) and `ros1` messages, written by the `mcap` package's writer with
# the messages serialized by `rosbags` (pip install mcap).
from mcap.writer import Writer as RawMcapWriter, CompressionType
definition, _ = ts.generate_msgdef(Imu.__msgtype__)
with open('tests/data/py-ros1.mcap', 'wb') as f:
    w = RawMcapWriter(f, compression=CompressionType.ZSTD)
    w.start(profile='ros1', library='make_fixtures.py')
    sid = w.register_schema(name='sensor_msgs/Imu', encoding='ros1msg', data=definition.encode())
    cid = w.register_channel(topic='/imu', message_encoding='ros1', schema_id=sid)
    for i in range(300):
        m = Imu(Header(i, Time(1700000000 + i//100, (i%100)*10_000_000), 'imu'), Q(0,0,0,1), np.zeros(9), V(i*0.5,0,0), np.zeros(9), V(0,0,-9.81), np.zeros(9))
        t = (1700000000 + i//100)*10**9 + (i%100)*10_000_000 + 5
        w.add_message(channel_id=cid, log_time=t, data=bytes(ts.serialize_ros1(m, Imu.__msgtype__)), publish_time=t, sequence=i)
    w.finish()
