"""Camera sources through OpenCV ``VideoCapture``, each on its own grab thread.

A source string picks the backend (``backend: auto``):

* ``0``, ``/dev/video0``: a V4L2 (USB, frame grabber) device;
* ``rtsp://``, ``rtsps://``, ``http://``, ``https://``, ``udp://``, ``tcp://``: a
  network stream through FFmpeg (RTSP from IP cameras, MJPEG over HTTP, ...);
* a string with ``!`` in it: a GStreamer pipeline ending in ``appsink`` (e.g.
  the BlueROV2's H.264 video: ``udpsrc port=5600 ! application/x-rtp,payload=96
  ! rtph264depay ! avdec_h264 ! videoconvert ! appsink``) - only where OpenCV
  was built with GStreamer (pip's wheels are not: then connecting says so);
* a folder: its images (png, jpg, bmp, tif) in name order, at ``fps``;
* another file: a video file, at ``fps`` (default: the file's rate).

Every frame is stamped with the backend clock when it is grabbed (before it is
decoded), which is what pairs the two cameras of a stereo rig. Frames that
fail to decode (``read`` returns nothing, an empty or mis-sized image) are
counted as corrupt and dropped. A live source that stops delivering is
reopened with back-off; files and folders end (or ``loop``). Nothing here
decides whether a frame is too old: :meth:`CameraSource.health` reports its
age against ``stale_timeout``.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from hal.interfaces import Health, HealthState

log = logging.getLogger(__name__)

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm")
STREAM_PREFIXES = ("rtsp://", "rtsps://", "http://", "https://", "udp://", "tcp://", "rtp://", "rtmp://")
BACKENDS = ("auto", "v4l2", "ffmpeg", "gstreamer", "images")


class CameraError(RuntimeError):
    """A camera cannot be opened or read; the message names it and says why."""


@dataclass(frozen=True)
class Frame:
    """One image: ``t`` backend time (s) of its grab, ``image`` BGR uint8, ``seq`` its number."""

    t: float
    image: np.ndarray
    seq: int


def source_kind(source: str, backend: str = "auto") -> str:
    """``v4l2``, ``ffmpeg`` (streams and video files), ``gstreamer`` or ``images``."""
    if backend != "auto":
        return backend
    s = str(source).strip()
    if s.isdigit() or s.startswith("/dev/video"):
        return "v4l2"
    if "!" in s:
        return "gstreamer"
    if s.lower().startswith(STREAM_PREFIXES):
        return "ffmpeg"
    if Path(s).is_dir():
        return "images"
    return "ffmpeg"


def is_live(kind: str, source: str) -> bool:
    """True for devices and network streams (reopened when they stop), False for files."""
    return kind in ("v4l2", "gstreamer") or str(source).lower().startswith(STREAM_PREFIXES)


def _quiet_opencv() -> None:
    """Keep OpenCV's own warnings (e.g. "can't capture by name") off the terminal:
    a source that cannot be opened is reported by :class:`CameraError`."""
    try:
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    except AttributeError:  # an OpenCV build without the logging utilities
        pass


def gstreamer_available() -> bool:
    return any("GStreamer" in line and "YES" in line for line in cv2.getBuildInformation().splitlines())


class _FolderCapture:
    """A folder of images with the ``read()`` of a ``VideoCapture``."""

    def __init__(self, folder: Path, loop: bool) -> None:
        self.files = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        self.loop = loop
        self.i = 0

    def isOpened(self) -> bool:  # noqa: N802 - VideoCapture's name
        return bool(self.files)

    def read(self) -> tuple[bool, np.ndarray | None]:
        if self.i >= len(self.files):
            if not self.loop:
                return False, None
            self.i = 0
        path = self.files[self.i]
        self.i += 1
        return True, cv2.imread(str(path), cv2.IMREAD_COLOR)  # None for a corrupt file: counted by the caller

    def release(self) -> None:
        self.files = []


def open_capture(
    source: str,
    kind: str,
    *,
    width: int | None = None,
    height: int | None = None,
    fps: float | None = None,
    loop: bool = False,
) -> cv2.VideoCapture | _FolderCapture:
    """Open ``source`` with the backend ``kind``; raise :class:`CameraError` if it cannot be opened."""

    _quiet_opencv()

    if kind == "images":
        folder = Path(source)
        if not folder.is_dir():
            raise CameraError(f"image folder {source} does not exist")
        images = _FolderCapture(folder, loop)
        if not images.isOpened():
            raise CameraError(f"image folder {source} holds no images ({', '.join(IMAGE_SUFFIXES)})")
        return images
    if kind == "gstreamer" and not gstreamer_available():
        raise CameraError(
            "this OpenCV has no GStreamer support (pip's opencv-python-headless has none): use an RTSP/HTTP URL, "
            "or install an OpenCV built with GStreamer"
        )
    api = {"v4l2": cv2.CAP_V4L2, "ffmpeg": cv2.CAP_FFMPEG, "gstreamer": cv2.CAP_GSTREAMER}[kind]
    target: str | int = int(source) if str(source).isdigit() else str(source)
    if kind == "ffmpeg" and not str(source).lower().startswith(STREAM_PREFIXES) and not Path(str(source)).is_file():
        raise CameraError(f"video file {source} does not exist")
    params = [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, 5000, cv2.CAP_PROP_READ_TIMEOUT_MSEC, 2000] if kind == "ffmpeg" else []
    cap = cv2.VideoCapture(target, api, params) if params else cv2.VideoCapture(target, api)
    if not cap.isOpened():
        cap.release()
        raise CameraError(f"cannot open {source} ({kind})")
    for prop, value in (
        (cv2.CAP_PROP_FRAME_WIDTH, width),
        (cv2.CAP_PROP_FRAME_HEIGHT, height),
        (cv2.CAP_PROP_FPS, fps),
    ):
        if value and kind == "v4l2":
            cap.set(prop, float(value))
    if kind == "v4l2":
        cap.set(cv2.CAP_PROP_BUFFERSIZE, 1)  # the newest frame, not a queue of old ones
    return cap


class CameraSource:
    """One camera: a grab thread keeps the last frames (``history``) with their times.

    params: ``source`` and optional ``backend``, ``width``, ``height``, ``fps``,
    ``loop`` (files and folders), ``stale_timeout`` (s). ``clock``: the backend clock.
    """

    def __init__(self, name: str, params: dict, clock: Callable[[], float], history: int = 8):
        self.name = name
        self.source = str(params["source"])
        self.kind = source_kind(self.source, params.get("backend") or "auto")
        self.width, self.height = params.get("width"), params.get("height")
        self.fps = params.get("fps")
        self.loop = bool(params.get("loop", False))
        self.stale_timeout = float(params.get("stale_timeout", 0.5))
        self.live = is_live(self.kind, self.source)
        self._clock = clock
        self._lock = threading.Lock()
        self._frames: deque[Frame] = deque(maxlen=history)
        self._cap: cv2.VideoCapture | _FolderCapture | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._seq = 0
        self.corrupt = 0
        self.reopens = 0
        self.ended = False
        self.last_error = ""
        self._times: deque[float] = deque(maxlen=30)
        self._size: tuple[int, int] | None = None

    # ------------------------------------------------------------------ life cycle

    def connect(self, start_thread: bool = True) -> None:
        """Open the source (raises :class:`CameraError`) and start grabbing."""
        try:
            self._cap = open_capture(
                self.source, self.kind, width=self.width, height=self.height, fps=self.fps, loop=self.loop
            )
        except CameraError as exc:
            raise CameraError(f"camera {self.name}: {exc}") from None
        self._period = self._file_period()
        self._stop.clear()
        if start_thread:
            self._thread = threading.Thread(target=self._run, name=f"camera-{self.name}", daemon=True)
            self._thread.start()

    def disconnect(self) -> None:
        """Stop grabbing and release the device. Idempotent."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=3.0)
            self._thread = None
        if self._cap is not None:
            try:
                self._cap.release()
            except Exception:  # noqa: BLE001 - releasing must not fail the shutdown
                pass
            self._cap = None

    def _file_period(self) -> float:
        """Seconds between frames of a file or folder (0: as fast as the device delivers)."""
        if self.live:
            return 0.0
        if self.fps:
            return 1.0 / float(self.fps)
        if self.kind == "images":
            return 0.1

        rate = self._cap.get(cv2.CAP_PROP_FPS) if isinstance(self._cap, cv2.VideoCapture) else 0.0
        return 1.0 / rate if rate and rate > 0 else 0.1

    # ------------------------------------------------------------------ grabbing

    def grab_once(self) -> tuple[str, Frame | None]:
        """Read one frame now (the thread does this in a loop): ``("ok", frame)``,
        ``("corrupt", None)`` (counted, dropped) or ``("none", None)`` (nothing came)."""
        cap = self._cap
        if cap is None:
            return "none", None
        if isinstance(cap, cv2.VideoCapture):  # every kind but "images"
            ok = cap.grab()
            t = self._clock()
            img = cap.retrieve()[1] if ok else None
        else:
            ok, img = cap.read()
            t = self._clock()
        if not ok:
            return "none", None
        if img is None or not isinstance(img, np.ndarray) or img.size == 0 or img.ndim != 3 or img.dtype != np.uint8:
            self.corrupt += 1
            self.last_error = "corrupt frame (could not be decoded)"
            return "corrupt", None
        size = (img.shape[1], img.shape[0])
        if self._size is not None and size != self._size:
            self.corrupt += 1
            self.last_error = f"frame size changed from {self._size[0]}x{self._size[1]} to {size[0]}x{size[1]}"
            return "corrupt", None
        self._size = size
        self._seq += 1
        frame = Frame(t, img, self._seq)
        with self._lock:
            self._frames.append(frame)
            self._times.append(t)
        return "ok", frame

    def _run(self) -> None:
        backoff = 0.2
        next_t = time.monotonic()
        while not self._stop.is_set():
            if self._period > 0:
                delay = next_t - time.monotonic()
                if delay > 0 and self._stop.wait(delay):
                    break
                next_t = max(next_t + self._period, time.monotonic() - self._period)
            status, _ = self.grab_once()
            if status != "none":
                backoff = 0.2
                continue
            if self._cap is None:
                break
            if not self.live:
                if self.loop and self.kind == "ffmpeg":
                    self._reopen()
                    continue
                self.ended = True
                self.last_error = "end of the recording"
                break
            # a live source delivered nothing: wait, then reopen it
            self.last_error = "no frame from the device"
            if self._stop.wait(backoff):
                break
            backoff = min(backoff * 2.0, 5.0)
            self._reopen()

    def _reopen(self) -> None:
        try:
            if self._cap is not None:
                self._cap.release()
            self._cap = open_capture(
                self.source, self.kind, width=self.width, height=self.height, fps=self.fps, loop=self.loop
            )
            self.reopens += 1
        except CameraError as exc:
            self.last_error = str(exc)
        except Exception as exc:  # noqa: BLE001 - a driver may fail any way; keep trying
            self.last_error = f"reopen failed: {exc}"

    # ------------------------------------------------------------------ readings

    def latest(self) -> Frame | None:
        with self._lock:
            return self._frames[-1] if self._frames else None

    def history(self) -> list[Frame]:
        with self._lock:
            return list(self._frames)

    def rate_hz(self) -> float | None:
        """Frame rate over the last frames (Hz)."""
        with self._lock:
            ts = list(self._times)
        if len(ts) < 2 or ts[-1] <= ts[0]:
            return None
        return (len(ts) - 1) / (ts[-1] - ts[0])

    def details(self, now: float) -> dict:
        """What ``maris hal check`` shows: source, resolution, frame rate, age of the last frame."""
        last = self.latest()
        return {
            "source": self.source if len(self.source) <= 60 else self.source[:57] + "...",
            "resolution": f"{self._size[0]}x{self._size[1]}" if self._size else None,
            "fps": None if (rate := self.rate_hz()) is None else round(rate, 1),
            "frame_age_s": None if last is None else round(now - last.t, 3),
            "frames": self._seq,
            "corrupt": self.corrupt,
            "reopens": self.reopens,
        }

    def health(self, now: float) -> Health:
        info = self.details(now)
        last = self.latest()
        if self._cap is None and last is None:
            return Health(HealthState.MISSING, now, f"camera {self.name}: not connected", info)
        if last is None or (self.rate_hz() is None and not self.ended):
            why = f" ({self.last_error})" if self.last_error else ""
            got = "no frame yet" if last is None else "waiting for a second frame (frame rate unknown)"
            return Health(HealthState.MISSING, now, f"camera {self.name}: {got}{why}", info)
        age = now - last.t
        if age > self.stale_timeout:
            why = f": {self.last_error}" if self.last_error else ""
            return Health(
                HealthState.FAULT,
                now,
                f"camera {self.name}: stale ({age:.2f} s old, limit {self.stale_timeout:.2f} s){why}",
                info,
            )
        return Health(HealthState.OK, now, "", info)
