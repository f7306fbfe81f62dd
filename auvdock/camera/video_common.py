"""What the camera video receiver and sender share: the RTP/H.264 stream conventions, PyAV, the error.

:mod:`auvdock.camera.video_in` receives the BlueOS camera stream and :mod:`auvdock.camera.video_out` sends
one for tests and rehearsals; both speak RTP over UDP with H.264 in dynamic payload type
:data:`RTP_PAYLOAD_TYPE` (90 kHz RTP clock) on a UDP port whose successor carries RTCP (so ports are
1-65534), both need PyAV (FFmpeg), and both raise :class:`VideoSourceError` when a correctly specified
device, port, encoder, decoder or file does not work.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

__all__ = [
    "RTP_PAYLOAD_TYPE",
    "VideoSourceError",
    "check_payload_type",
    "check_rtp_port",
    "import_av",
]

#: RTP payload type of the H.264 stream (BlueOS default, the first dynamic type).
RTP_PAYLOAD_TYPE = 96


class VideoSourceError(RuntimeError):
    """A source that was correctly specified cannot be opened or read (device, port, decoder, file)."""


def import_av() -> ModuleType:
    """The ``av`` (PyAV) module; ImportError with the install command if it is missing."""
    try:
        import av
    except ImportError as exc:  # pragma: no cover - av is a dependency
        raise ImportError("PyAV is needed for RTP streams and video files: python -m pip install av") from exc
    return av


def check_rtp_port(port: Any, where: str) -> int:
    """``port`` if it is an RTP UDP port (1-65534: RTCP uses ``port + 1``); ValueError naming ``where``."""
    if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65534:
        raise ValueError(f"{where}: UDP port must be 1-65534 (RTCP uses port + 1), got {port!r}")
    return port


def check_payload_type(payload_type: Any) -> int:
    """``payload_type`` if it is a dynamic RTP payload type (96-127); ValueError otherwise."""
    if isinstance(payload_type, bool) or not isinstance(payload_type, int) or not 96 <= payload_type <= 127:
        raise ValueError(f"payload_type: expected a dynamic RTP payload type 96-127, got {payload_type!r}")
    return payload_type
