"""The iiwa driver's LCM messages as arrays: what drake-iiwa-driver (torque-only mode) and
`hlcmp sim-driver` publish, and what `hlcmp serve` answers.

    driver --lcmt_iiwa_status (every period)--> client
    driver --lcmt_force_torque (wrist sensor)--> client
    client --lcmt_iiwa_command (torques; positions echoed; the status's utime)--> driver

Decoding checks sizes and finiteness, so a bad message is a clear `ProtocolError`, never
an index error deep in a controller.
"""

from __future__ import annotations

import dataclasses as dc
import functools
import re
import struct
from typing import Any

import numpy as np
from drake import lcmt_force_torque, lcmt_iiwa_command, lcmt_iiwa_status
from pydrake.lcm import DrakeLcm

from hlcmp_drake.io.errors import InputError


class ProtocolError(Exception):
    """A message that does not decode, or holds the wrong number of joints or a non-finite value."""


def _decode(message_type: Any, data: bytes, what: str):
    try:
        return message_type.decode(data)
    except (ValueError, struct.error) as error:  # another type's bytes, or too few
        raise ProtocolError(
            f"{what} that does not decode as {message_type.__name__} ({error})"
        ) from None


@dc.dataclass(frozen=True)
class IiwaStatus:
    """One lcmt_iiwa_status: the arm's state as the driver measured it.

    Attributes
    ----------
    utime : int
        The driver's time stamp [µs].
    position : (n,) array
        Measured joint positions [rad].
    velocity : (n,) array
        Estimated joint velocities [rad/s].
    torque_commanded : (n,) array
        The joint torque commanded, gravity compensation included, negated: Drake's
        simulated iiwa reports it so (manipulation/README.md), not the client's command
        alone [N m].
    torque_measured : (n,) array
        The joint torque sensors' reading, negated, as the iiwa reports it (in Drake's
        simulation, the same as `torque_commanded`) [N m].
    torque_external : (n,) array
        The driver's estimate of the external joint torques, positive along the joint
        motion an external force drives (not negated) [N m].
    """

    utime: int
    position: np.ndarray
    velocity: np.ndarray
    torque_commanded: np.ndarray
    torque_measured: np.ndarray
    torque_external: np.ndarray


def encode_status(status: IiwaStatus) -> bytes:
    """The lcmt_iiwa_status bytes of `status` (the interpolator's position is the measured one).

    Parameters
    ----------
    status : IiwaStatus

    Returns
    -------
    bytes
    """
    message = lcmt_iiwa_status()
    message.utime = int(status.utime)
    message.num_joints = len(status.position)
    position = np.asarray(status.position, dtype=float).tolist()
    message.joint_position_measured = position
    message.joint_velocity_estimated = np.asarray(status.velocity, dtype=float).tolist()
    message.joint_position_commanded = position
    message.joint_position_ipo = position
    message.joint_torque_measured = np.asarray(status.torque_measured, dtype=float).tolist()
    message.joint_torque_commanded = np.asarray(status.torque_commanded, dtype=float).tolist()
    message.joint_torque_external = np.asarray(status.torque_external, dtype=float).tolist()
    return message.encode()


def decode_status(data: bytes, num_joints: int) -> IiwaStatus:
    """An IiwaStatus from lcmt_iiwa_status bytes, read in place (`_STATUS_HEADER`, then the
    type's double arrays as one block: every status of a served run is decoded, and
    lcm's own decoder costs several times as much; tested equal to it).

    Parameters
    ----------
    data : bytes
    num_joints : int
        The number of joints the message must hold.

    Returns
    -------
    IiwaStatus

    Raises
    ------
    ProtocolError
        When the bytes do not decode or hold another number of joints. Non-finite values
        are passed on: the client's watchdog names them.
    """
    utime = _checked_status(data, num_joints)
    rows = (
        np.frombuffer(data, ">f8", len(_STATUS_ARRAYS) * num_joints, _STATUS_HEADER.size)
        .astype(float)
        .reshape(len(_STATUS_ARRAYS), num_joints)
    )
    return IiwaStatus(utime, *(rows[k] for k in _STATUS_ROWS))


def read_status_state(data: bytes, num_joints: int) -> tuple[int, tuple, tuple, tuple]:
    """What a served tick reads of lcmt_iiwa_status bytes, as plain floats: no array is
    made, since each numpy call costs several microseconds on the cold caches a tick
    starts from, 5 ms after the last one (docs/performance.md). Checked as
    `decode_status` checks.

    Parameters
    ----------
    data : bytes
    num_joints : int
        The number of joints the message must hold.

    Returns
    -------
    utime : int
    position, velocity, torque_external : tuple of float
        As `IiwaStatus`'s fields of those names.

    Raises
    ------
    ProtocolError
        As `decode_status`.
    """
    utime = _checked_status(data, num_joints)
    row = _status_row(num_joints)
    position, velocity, external = (row.unpack_from(data, at) for at in _state_offsets(num_joints))
    return utime, position, velocity, external


def _checked_status(data: bytes, num_joints: int) -> int:
    """The utime of lcmt_iiwa_status bytes of `num_joints` joints; ProtocolError else."""
    if len(data) < _STATUS_HEADER.size or data[:8] != _STATUS_FINGERPRINT:
        _decode(lcmt_iiwa_status, data, "a status")  # says what is wrong, in lcm's words
    _, utime, joints = _STATUS_HEADER.unpack_from(data)
    if joints != num_joints:
        raise ProtocolError(f"a status for {joints} joints, the arm has {num_joints}")
    size = _STATUS_HEADER.size + 8 * len(_STATUS_ARRAYS) * joints
    if len(data) != size:
        raise ProtocolError(f"a status of {len(data)} bytes, where {joints} joints make {size}")
    return utime


@functools.lru_cache(maxsize=8)
def _status_row(joints: int) -> struct.Struct:
    """One of lcmt_iiwa_status's arrays on the wire: `joints` big-endian doubles."""
    return struct.Struct(f">{joints}d")


@functools.lru_cache(maxsize=8)
def _state_offsets(joints: int) -> tuple[int, int, int]:
    """Where the measured positions, estimated velocities and external torques start."""
    return tuple(
        _STATUS_HEADER.size + 8 * joints * _STATUS_ARRAYS.index(field)
        for field in (
            "joint_position_measured",
            "joint_velocity_estimated",
            "joint_torque_external",
        )
    )


_STATUS_FINGERPRINT = lcmt_iiwa_status._get_packed_fingerprint()
# lcmt_iiwa_status on the wire (LCM is big-endian): the type's fingerprint, utime (int64),
# num_joints (int32), then its arrays of num_joints doubles in the order of its fields.
_STATUS_HEADER = struct.Struct(">8sqi")
_STATUS_ARRAYS = lcmt_iiwa_status.__slots__[2:]
# IiwaStatus's arrays, by their fields' places among the type's arrays.
_STATUS_ROWS = tuple(
    _STATUS_ARRAYS.index(field)
    for field in (
        "joint_position_measured",
        "joint_velocity_estimated",
        "joint_torque_commanded",
        "joint_torque_measured",
        "joint_torque_external",
    )
)


def status_stamp(data: bytes) -> int | None:
    """The time stamp of lcmt_iiwa_status bytes, read from the header alone (the LCM
    fingerprint, then `utime` as a big-endian int64): cheap enough for every status
    received, decoded or not.

    Parameters
    ----------
    data : bytes

    Returns
    -------
    int or None
        [µs]; None when the bytes are not an lcmt_iiwa_status.
    """
    if len(data) < 16 or data[:8] != _STATUS_FINGERPRINT:
        return None
    return int.from_bytes(data[8:16], "big", signed=True)


def encode_torque_command(utime: int, position: np.ndarray, torque: np.ndarray) -> bytes:
    """The lcmt_iiwa_command bytes of a torque-only command.

    Parameters
    ----------
    utime : int
        The answered status's time stamp [µs].
    position : (n,) array or sequence of float
        The measured positions, echoed: a torque-only driver ignores them, a position
        driver would hold them [rad].
    torque : (n,) array or sequence of float
        The joint torque to apply on top of the driver's gravity compensation [N m].

    Returns
    -------
    bytes
    """
    return _command_layout(len(position), len(torque)).pack(
        _COMMAND_FINGERPRINT, int(utime), len(position), *position, len(torque), *torque
    )


_COMMAND_FINGERPRINT = lcmt_iiwa_command._get_packed_fingerprint()


@functools.lru_cache(maxsize=8)
def _command_layout(joints: int, torques: int) -> struct.Struct:
    """lcmt_iiwa_command on the wire: fingerprint, utime, num_joints, joint_position,
    num_torques, joint_torque (tested equal to lcm's own encoding)."""
    return struct.Struct(f">8sqi{joints}di{torques}d")


def decode_torque_command(data: bytes, num_joints: int) -> tuple[int, np.ndarray]:
    """The time stamp and the torques of an lcmt_iiwa_command.

    Parameters
    ----------
    data : bytes
        The message as received.
    num_joints : int
        How many torques a torque-only command carries (the arm's joints).

    Returns
    -------
    utime : int
        The answered status's time stamp [µs].
    torque : (n,) array
        [N m].

    Raises
    ------
    ProtocolError
        When the bytes do not decode, hold another number of torques (a position-only
        command has none), or a non-finite torque.
    """
    message = _decode(lcmt_iiwa_command, data, "a command")
    if message.num_torques != num_joints:
        raise ProtocolError(
            f"a command with {message.num_torques} torques; torque-only mode needs {num_joints}"
        )
    torque = np.array(message.joint_torque)
    if not np.all(np.isfinite(torque)):
        raise ProtocolError(f"a command with a non-finite torque: {torque}")
    return message.utime, torque


def encode_wrench(utime: int, force: np.ndarray, torque: np.ndarray) -> bytes:
    """The lcmt_force_torque bytes of a wrist sensor's reading.

    Parameters
    ----------
    utime : int
        The time stamp [µs] (the status it belongs to).
    force : (3,) array
        The environment's force on the tool, in the tool frame [N].
    torque : (3,) array
        The environment's torque on the tool about the tool point, in the tool frame [N m].

    Returns
    -------
    bytes
    """
    message = lcmt_force_torque()
    message.timestamp = int(utime)
    message.fx, message.fy, message.fz = map(float, force)
    message.tx, message.ty, message.tz = map(float, torque)
    return message.encode()


def decode_wrench(data: bytes) -> tuple[int, np.ndarray, np.ndarray]:
    """The time stamp, the force and the torque of an lcmt_force_torque.

    Parameters
    ----------
    data : bytes

    Returns
    -------
    utime : int
        [µs].
    force : (3,) array
        [N], in the sensor's frame.
    torque : (3,) array
        [N m], about the sensor's origin, in its frame.

    Raises
    ------
    ProtocolError
        When the bytes do not decode.
    """
    message = _decode(lcmt_force_torque, data, "a wrist message")
    force = np.array([message.fx, message.fy, message.fz])
    return message.timestamp, force, np.array([message.tx, message.ty, message.tz])


# LCM's udpm options, each to the whole numbers it takes (recv_buf_size 0: LCM's default).
# LCM warns about any other value and runs on, with no traffic or the default in its place.
UDPM_OPTIONS = {"ttl": range(0, 256), "recv_buf_size": range(0, 2**31)}


def _udpm_options_problem(query: str) -> str | None:
    """What is wrong with a udpm:// URL's options ("ttl=0&recv_buf_size=2097152", LCM also
    splits at commas), or None."""
    for option in filter(None, re.split("[,&]", query)):
        key, _, value = option.partition("=")
        allowed = UDPM_OPTIONS.get(key)
        if allowed is None:
            return f"unknown option '{key}': udpm:// takes {' and '.join(UDPM_OPTIONS)}"
        # Plain decimal digits only: LCM reads a leading 0 as octal (010 is 8, 08 is 0).
        if not (re.fullmatch("0|[1-9][0-9]*", value) and int(value) in allowed):
            return (
                f"{key} must be a whole number from {allowed.start} to {allowed.stop - 1} "
                f"(decimal, no leading zero), got '{value}'"
            )
    return None


def open_lcm(url: str) -> DrakeLcm:
    """A DrakeLcm on `url`, checked first: LCM itself only prints a bad URL and then
    neither sends nor receives.

    Parameters
    ----------
    url : str
        memq:// (this process only) or udpm://GROUP:PORT[?ttl=0], GROUP an IPv4
        multicast address (ttl=0 keeps the traffic on this machine); the options are
        LCM's ttl and recv_buf_size, whole numbers.

    Returns
    -------
    DrakeLcm

    Raises
    ------
    InputError
        For any other URL.
    """
    if url != "memq://":
        match = re.fullmatch(r"udpm://(\d+)\.(\d+)\.(\d+)\.(\d+):(\d+)(?:\?(.*))?", url)
        octets = [int(g) for g in match.groups()[:4]] if match else []
        if not (
            match
            and 224 <= octets[0] <= 239
            and max(octets) <= 255
            and 0 < int(match.group(5)) < 65536
        ):
            raise InputError(
                f"--lcm {url}: expected udpm://GROUP:PORT?ttl=0 with an IPv4 multicast GROUP "
                "(224.0.0.0 to 239.255.255.255), e.g. udpm://239.255.76.67:7667?ttl=0, or memq://"
            )
        problem = _udpm_options_problem(match.group(6) or "")
        if problem:
            raise InputError(f"--lcm {url}: {problem}")
    return DrakeLcm(url)
