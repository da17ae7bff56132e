"""Messages cut to fit where they are shown (the dock's status line, a row of the batch log)."""

from __future__ import annotations

__all__ = ["cut_at_word"]


def cut_at_word(text: str, limit: int) -> str:
    """``text`` cut at a word before ``limit`` characters, with an ellipsis.

    >>> cut_at_word("short", 12), cut_at_word("one two three four", 12)
    ('short', 'one two …')
    """
    if len(text) <= limit:
        return text
    cut = text.rfind(" ", 0, limit - 1)
    return text[:cut if cut > 0 else limit - 1].rstrip() + " …"
