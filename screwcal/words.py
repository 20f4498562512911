"""Numbers said in words a person reads: '1 pose', '3 poses' (never '1 poses')."""

from __future__ import annotations


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """'1 pose', '0 poses', '3 poses'; `plural` where adding an s is wrong ('1 axis',
    '2 axes')."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"
