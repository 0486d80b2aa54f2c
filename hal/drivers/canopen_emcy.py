"""Decoding CANopen emergency (EMCY) codes and the error register, for fault
messages an operator can act on.

An EMCY frame (CiA 301) carries the error code (2 bytes, little endian), the
error register 0x1001 (1 byte) and 5 manufacturer-specific bytes. The error
code's high byte names the error class (CiA 301 table "Emergency error
codes"); CiA 402 refines some of them for drives. An error code of 0x0000 means
"error reset or no error" (sent after a fault reset).

:func:`describe_emcy` turns code + register into one readable phrase, e.g.
``EMCY 0x8130 (life guard or heartbeat error), error register 0x11 (generic,
communication)``.
"""

from __future__ import annotations

#: Exact codes we know (CiA 301 / CiA 402 names, in our words).
EMCY_CODES: dict[int, str] = {
    0x0000: "no error / error reset",
    0x1000: "generic error",
    0x2310: "continuous over-current",
    0x2320: "short circuit at the outputs",
    0x3210: "DC link over-voltage",
    0x3220: "DC link under-voltage",
    0x4210: "excess temperature of the device",
    0x4310: "excess temperature of the drive",
    0x5530: "non-volatile memory error",
    0x6100: "internal software error",
    0x7121: "motor blocked",
    0x7300: "sensor (encoder) error",
    0x7500: "communication error (drive internal)",
    0x8110: "CAN overrun (frames lost)",
    0x8120: "CAN in error passive mode",
    0x8130: "life guard or heartbeat error (the watched node went silent)",
    0x8140: "recovered from bus off",
    0x8210: "PDO not processed: length error",
    0x8220: "PDO length exceeded",
    0x8611: "following error too large",
    0x9000: "external error",
}

#: Error classes by the code's high nibble / byte (CiA 301).
EMCY_CLASSES: list[tuple[int, int, str]] = [  # (mask, value, class)
    (0xFF00, 0xFF00, "device-specific error"),
    (0xFF00, 0xF000, "additional functions error"),
    (0xFF00, 0x8100, "communication error"),
    (0xFF00, 0x8200, "protocol error"),
    (0xFF00, 0x8600, "position/velocity control monitoring"),
    (0xF000, 0x8000, "monitoring error"),
    (0xF000, 0x9000, "external error"),
    (0xF000, 0x7000, "additional modules error"),
    (0xF000, 0x6000, "device software error"),
    (0xF000, 0x5000, "device hardware error"),
    (0xF000, 0x4000, "temperature error"),
    (0xF000, 0x3000, "voltage error"),
    (0xF000, 0x2000, "current error"),
    (0xF000, 0x1000, "generic error"),
]

#: Error register 0x1001 bits (CiA 301).
ERROR_REGISTER_BITS: tuple[str, ...] = (
    "generic",
    "current",
    "voltage",
    "temperature",
    "communication",
    "device profile specific",
    "reserved",
    "manufacturer specific",
)


def emcy_text(code: int) -> str:
    """What an EMCY error code means (exact name, else its class)."""
    if code in EMCY_CODES:
        return EMCY_CODES[code]
    for mask, value, name in EMCY_CLASSES:
        if code & mask == value:
            return name
    return "unknown error code"


def error_register_text(register: int) -> str:
    """Names of the bits set in the error register, comma separated ("none" if 0)."""
    names = [n for bit, n in enumerate(ERROR_REGISTER_BITS) if register >> bit & 1]
    return ", ".join(names) if names else "none"


def describe_emcy(code: int | None, register: int | None = None) -> str:
    """``EMCY 0x8130 (life guard ...), error register 0x11 (generic, communication)``;
    parts that are unknown (None) are left out; empty string if both are."""
    parts = []
    if code is not None:
        parts.append(f"EMCY 0x{code:04X} ({emcy_text(code)})")
    if register is not None:
        parts.append(f"error register 0x{register:02X} ({error_register_text(register)})")
    return ", ".join(parts)


def parse_emcy(data: bytes | bytearray) -> tuple[int, int | None]:
    """(error code, error register or None) of an EMCY frame's data."""
    code = int.from_bytes(bytes(data[0:2]), "little")
    register = data[2] if len(data) >= 3 else None
    return code, register
