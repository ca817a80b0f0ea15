"""Numbers and text written by compiled kernels as C and C++ print them: ``%d`` of a whole number and
``%.6g`` of a double (a default C++ ostream's ``<<``), byte for byte, into a uint8 buffer; the writers of
rcssserver's texts (the game log's show line, ``server.show_text``; a player's see, ``rcss.see_text``).

**The numbers.** ``%.6g`` is the double's exact binary value rounded to 6 significant digits, ties to
even, then the shorter of the fixed and the exponent forms by C's rule, trailing zeros dropped (-0
printed "-0"). :func:`_rounded` decides that rounding on the exact value: it scales by a power of ten
that a double holds exactly (10^k, |k| <= 22) and carries the product's rounding error along (Dekker's
exact product), so a value just below or above a tie rounds as printf rounds it. A number outside
[``SMALLEST``, ``LARGEST``) in magnitude, NaN or an infinity, is not written (:func:`put_number` returns
-1): the caller formats it in Python (tests/test_show_line.py checks the writer against ``%.6g``).

Each writer puts its text at ``out[at:]`` and returns the position after it.
"""

from __future__ import annotations

import math

import numpy as np

from keepaway.core.jit import borrowing

# the magnitudes the kernel prints itself: 10^k of the scaling stays exact (|k| <= 22, see _rounded)
SMALLEST = 1e-16
LARGEST = 1e26

_POW10 = np.array([10.0 ** k for k in range(23)])  # exact doubles
_SPLITTER = 134217729.0  # 2^27 + 1 (Veltkamp's split of a double into two 26-bit halves)
_MINUS, _PLUS, _DOT, _ZERO, _E = (ord(c) for c in "-+.0e")


@borrowing(inline="always")
def put_text(out, at, text, start=0, end=-1) -> int:
    """``text[start:end]`` (end -1: to its end) at ``out[at:]``; its end."""
    if end < 0:
        end = len(text)
    for i in range(start, end):
        out[at + i - start] = text[i]
    return at + end - start


@borrowing
def put_whole(out, at, value) -> int:
    """A whole number ``value`` (int64) in decimal (digits from the last: a division by the constant 10
    is a multiplication)."""
    if value < 0:
        out[at] = _MINUS
        at += 1
        value = -value
    n_digits = 1
    rest = value
    while rest >= 10:
        rest //= 10
        n_digits += 1
    for i in range(at + n_digits - 1, at - 1, -1):
        out[i] = _ZERO + value % 10
        value //= 10
    return at + n_digits


@borrowing
def _two_product(a, b) -> tuple:
    """(p, e): p = a * b rounded, p + e = a * b exactly (Dekker; no overflow or underflow here)."""
    p = a * b
    c = _SPLITTER * a
    a_hi = c - (c - a)
    a_lo = a - a_hi
    c = _SPLITTER * b
    b_hi = c - (c - b)
    b_lo = b - b_hi
    return p, ((a_hi * b_hi - p) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo


@borrowing
def _rounded(a, k) -> int:
    """``a * 10^k`` rounded to a whole number, ties to even, decided on the exact value (|k| <= 22, the
    product between 10^4 and 10^7). With k >= 0 the product is exact as h + l; the sign of
    (h - n - 1/2) + l, each step exact but the last, whose sign is the exact sum's, says which side of
    n + 1/2 it lies. With k < 0 the quotient's n is compared the other way round: a against
    (n + 1/2) 10^-k, held exactly as h + l."""
    if k >= 0:
        h, l = _two_product(a, _POW10[k])
        n = math.floor(h)
        side = ((h - n) - 0.5) + l
    else:
        n = math.floor(a / _POW10[-k])
        h, l = _two_product(n + 0.5, _POW10[-k])
        side = (a - h) - l
    if side > 0.0 or (side == 0.0 and n % 2 == 1):
        return n + 1
    return n


@borrowing
def put_number(out, at, x) -> int:
    """``x`` as ``%.6g`` prints it, at ``out[at:]``; its end, or -1 for a hole (nothing written)."""
    if x == 0.0:
        if math.copysign(1.0, x) < 0.0:
            out[at] = _MINUS
            at += 1
        out[at] = _ZERO
        return at + 1
    a = abs(x)
    if not SMALLEST <= a < LARGEST:  # NaN too
        return -1
    if x < 0.0:
        out[at] = _MINUS
        at += 1
    k = 5 - math.floor(math.log10(a))  # so that 10^5 <= a 10^k < 10^6, but log10 may miss by one
    digits = _rounded(a, k)
    while digits < 100_000 or digits > 1_000_000:
        k += 1 if digits < 100_000 else -1
        digits = _rounded(a, k)
    exponent = 5 - k  # of the first digit
    if digits == 1_000_000:  # rounded up to the next power of ten
        digits = 100_000
        exponent += 1
    n_digits = 6
    while digits % 10 == 0:  # %g drops trailing zeros
        digits //= 10
        n_digits -= 1
    # where digit i goes, after `at`: d.ddddde+XX (exponent form), 0.000ddd or ddd.ddd and dddd00 (fixed)
    fixed = -4 <= exponent < 6
    if not fixed or exponent >= 0:
        first, point = 0, (1 if not fixed else exponent + 1)  # the digits before the point
        end = at + max(n_digits + (1 if n_digits > point else 0), point)
        if n_digits > point:
            out[at + point] = _DOT
        for i in range(at + n_digits, at + point):  # whole digits beyond the significant ones
            out[i] = _ZERO
    else:
        first, point = 1 - exponent, 6  # "0." and -exponent - 1 zeros, then the digits
        out[at] = _ZERO
        out[at + 1] = _DOT
        for i in range(at + 2, at + first):
            out[i] = _ZERO
        end = at + first + n_digits
    for i in range(n_digits - 1, -1, -1):
        out[at + first + i + (1 if i >= point else 0)] = _ZERO + digits % 10
        digits //= 10
    if fixed:
        return end
    out[end] = _E
    out[end + 1] = _MINUS if exponent < 0 else _PLUS
    end += 2
    if abs(exponent) < 10:
        out[end] = _ZERO
        end += 1
    return put_whole(out, end, abs(exponent))
