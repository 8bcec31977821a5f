"""The report's one pass over a bag reads the joint velocities (the run verdict's joint speeds) straight from the CDR
bytes: they are the decoded messages'.

The bag: test/data/e1_lockstep_4s (4 s of the default E1 run in lockstep, recorded by our recorder).
"""
from __future__ import annotations

from pathlib import Path

from mcap_ros2.decoder import DecoderFactory

from fic_teleop_tools.recording.bag_reader import read_messages
from fic_teleop_tools.report.bag_data import _cdr_joint_velocities

BAG = Path(__file__).resolve().parents[1] / "data" / "e1_lockstep_4s" / "bag"


def test_joint_velocities_from_the_cdr_bytes_are_the_decoded_messages():
    factory, decoder, checked = DecoderFactory(), None, 0
    for schema, channel, message in read_messages(BAG):
        if channel.topic != "/joint_states":
            continue
        decoder = decoder or factory.decoder_for(channel.message_encoding, schema)
        assert _cdr_joint_velocities(message.data) == tuple(decoder(message.data).velocity)
        checked += 1
    assert checked > 1000


def test_a_joint_state_with_another_frame_and_names_is_read_at_its_own_offsets():
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    message = JointState(name=["a", "joint_with_a_longer_name", "c"], position=[1.0, 2.0, 3.0],
                         velocity=[-0.5, 0.25, 7.0], effort=[])
    message.header.frame_id = "base_frame"
    assert _cdr_joint_velocities(serialize_message(message)) == (-0.5, 0.25, 7.0)
    assert _cdr_joint_velocities(serialize_message(JointState(name=["a"], position=[1.0]))) == ()
