"""hlcmp_drake.io.iiwa_lcm: the iiwa driver's LCM messages round trip, and bad ones are named."""

import numpy as np
import pytest

from hlcmp_drake.io.iiwa_lcm import (
    IiwaStatus,
    ProtocolError,
    decode_status,
    decode_torque_command,
    decode_wrench,
    encode_status,
    encode_torque_command,
    encode_wrench,
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
