"""Bounded field types shared by every message.

Every numeric field carries bounds (`msgspec.Meta` ge/le), so NaN, inf and absurd values are
rejected at decode; every string and list carries a maximum length. Units are SI and the field
name carries the unit suffix.
"""

from __future__ import annotations

from typing import Annotated

from msgspec import Meta

#: Largest payload any key may carry (bytes). The codec refuses larger ones before decoding.
MAX_PAYLOAD_BYTES = 1 << 20

U63 = Annotated[int, Meta(ge=0, le=(1 << 63) - 1)]
Seq = Annotated[int, Meta(ge=0, le=(1 << 63) - 1, description="per-publisher sequence number")]
StampNs = Annotated[int, Meta(ge=0, le=(1 << 63) - 1, description="sender wall clock, ns")]
ServiceName = Annotated[str, Meta(min_length=1, max_length=64, pattern=r"^[a-z0-9_.\-]+$")]
Identifier = Annotated[str, Meta(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.:\-]+$")]
Text = Annotated[str, Meta(max_length=512)]
JointName = Annotated[str, Meta(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_]+$")]

PositionM = Annotated[float, Meta(ge=-100.0, le=100.0)]
DistanceM = Annotated[float, Meta(ge=0.0, le=100.0)]
VelocityMS = Annotated[float, Meta(ge=-1000.0, le=1000.0)]
AccelMS2 = Annotated[float, Meta(ge=-10000.0, le=10000.0)]
SpeedMS = Annotated[float, Meta(ge=0.0, le=1000.0)]
AngleRad = Annotated[float, Meta(ge=-100.0, le=100.0)]
AngularVelocityRadS = Annotated[float, Meta(ge=-1000.0, le=1000.0)]
ForceN = Annotated[float, Meta(ge=-10000.0, le=10000.0)]
NonNegForceN = Annotated[float, Meta(ge=0.0, le=10000.0)]
TorqueNm = Annotated[float, Meta(ge=-10000.0, le=10000.0)]
MassKg = Annotated[float, Meta(ge=0.0, le=1000.0)]
DurationS = Annotated[float, Meta(ge=0.0, le=86400.0)]
FrequencyHz = Annotated[float, Meta(gt=0.0, le=100000.0)]
Fraction = Annotated[float, Meta(ge=0.0, le=1.0)]
Quaternion = Annotated[float, Meta(ge=-1.0, le=1.0)]
Cost = Annotated[float, Meta(ge=0.0, le=1e12)]

Vec3M = tuple[PositionM, PositionM, PositionM]
Vec2M = tuple[PositionM, PositionM]
Vec3ForceN = tuple[ForceN, ForceN, ForceN]
Vec3TorqueNm = tuple[TorqueNm, TorqueNm, TorqueNm]
Vec3VelocityMS = tuple[VelocityMS, VelocityMS, VelocityMS]
QuaternionXYZW = tuple[Quaternion, Quaternion, Quaternion, Quaternion]

MAX_JOINTS = 32
JointNames = Annotated[list[JointName], Meta(max_length=MAX_JOINTS)]
JointPositions = Annotated[list[AngleRad], Meta(max_length=MAX_JOINTS)]
JointVelocities = Annotated[list[AngularVelocityRadS], Meta(max_length=MAX_JOINTS)]
JointEfforts = Annotated[list[TorqueNm], Meta(max_length=MAX_JOINTS)]
