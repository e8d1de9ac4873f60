"""hlcmp_drake.io.iiwa_lcm: the iiwa driver's LCM messages round trip, and bad ones are named."""

import numpy as np
import pytest
from drake import lcmt_iiwa_command, lcmt_iiwa_status

from hlcmp_drake.io.iiwa_lcm import (
    IiwaStatus,
    ProtocolError,
    decode_status,
    decode_torque_command,
    decode_wrench,
    encode_status,
    encode_torque_command,
    encode_wrench,
    read_status_state,
)


def test_messages_round_trip_and_bad_ones_are_named():
    rng = np.random.default_rng(0)
    status = IiwaStatus(1234, *(rng.normal(size=7) for _ in range(5)))
    back = decode_status(encode_status(status), 7)
    assert back.utime == 1234
    for field in ("position", "velocity", "torque_commanded", "torque_measured", "torque_external"):
        np.testing.assert_array_equal(getattr(back, field), getattr(status, field))
    utime, torque = decode_torque_command(
        encode_torque_command(99, status.position, status.velocity), 7
    )
    assert utime == 99
    np.testing.assert_array_equal(torque, status.velocity)
    utime, force, torque = decode_wrench(encode_wrench(5, [1.0, -2.0, 3.0], [0.5, 0.25, -4.0]))
    assert utime == 5 and force.tolist() == [1.0, -2.0, 3.0]
    assert torque.tolist() == [0.5, 0.25, -4.0]
    with pytest.raises(ProtocolError, match="for 7 joints, the arm has 6"):
        decode_status(encode_status(status), 6)
    with pytest.raises(ProtocolError, match="does not decode"):
        decode_status(b"not a status", 7)
    with pytest.raises(ProtocolError, match="non-finite torque"):
        decode_torque_command(encode_torque_command(1, np.zeros(7), [np.nan] + [0.0] * 6), 7)
    with pytest.raises(ProtocolError, match="torque-only mode needs 7"):
        decode_torque_command(encode_torque_command(1, np.zeros(7), np.zeros(3)), 7)


@pytest.mark.parametrize("joints", [7, 3])
def test_statuses_read_in_place_equal_lcms_own_decoding(joints):
    rng = np.random.default_rng(joints)
    message = lcmt_iiwa_status()
    message.utime, message.num_joints = -(2**40) + 17, joints
    for field in lcmt_iiwa_status.__slots__[2:]:  # every array different
        setattr(message, field, rng.normal(size=joints).tolist())
    data = message.encode()
    ours, lcms = decode_status(data, joints), lcmt_iiwa_status.decode(data)
    assert ours.utime == lcms.utime
    for field, theirs in (
        ("position", "joint_position_measured"),
        ("velocity", "joint_velocity_estimated"),
        ("torque_commanded", "joint_torque_commanded"),
        ("torque_measured", "joint_torque_measured"),
        ("torque_external", "joint_torque_external"),
    ):
        array = getattr(ours, field)
        assert array.dtype == np.float64 and array.dtype.isnative and array.flags.c_contiguous
        assert array.tolist() == list(getattr(lcms, theirs))
    # The served tick's reading: the same numbers, as floats.
    utime, position, velocity, external = read_status_state(data, joints)
    assert utime == lcms.utime
    assert position == tuple(lcms.joint_position_measured)
    assert velocity == tuple(lcms.joint_velocity_estimated)
    assert external == tuple(lcms.joint_torque_external)
    for read in (decode_status, read_status_state):
        with pytest.raises(ProtocolError, match=f"a status of {len(data) - 8} bytes, where"):
            read(data[:-8], joints)
        with pytest.raises(ProtocolError, match="does not decode as lcmt_iiwa_status"):
            read(data[:12], joints)
        with pytest.raises(ProtocolError, match=f"for {joints} joints, the arm has 4"):
            read(data, 4)
    # Cut short on the network: one line from every decoder, never struct's own error.
    with pytest.raises(ProtocolError, match="does not decode as lcmt_force_torque"):
        decode_wrench(encode_wrench(5, [1.0, 2.0, 3.0], [0.0, 0.0, 0.0])[:-4])
    with pytest.raises(ProtocolError, match="does not decode as lcmt_iiwa_command"):
        decode_torque_command(encode_torque_command(5, np.zeros(7), np.zeros(7))[:-4], 7)


@pytest.mark.parametrize("joints, torques", [(7, 7), (7, 3), (2, 0)])
def test_commands_encode_as_lcm_encodes_them(joints, torques):
    rng = np.random.default_rng(joints + torques)
    position, torque = rng.normal(size=joints), rng.normal(size=torques)
    message = lcmt_iiwa_command()
    message.utime, message.num_joints, message.num_torques = 2**50 + 3, joints, torques
    message.joint_position, message.joint_torque = position.tolist(), torque.tolist()
    assert encode_torque_command(2**50 + 3, position, torque) == message.encode()
    # as the served tick gives them: the status's positions as a tuple, the torques a list
    assert (
        encode_torque_command(2**50 + 3, tuple(position.tolist()), torque.tolist())
        == message.encode()
    )
