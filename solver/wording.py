"""How rotsound words a count in its messages and log lines: "1 configuration", "2 configurations"."""


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` and ``noun`` in the number ``n`` asks for: the singular for 1 (and -1), else ``plural``
    (default: ``noun`` + "s"), as in "1 contact", "0 contacts", "3 packings".  Not collective."""
    return f"{n} {noun if abs(n) == 1 else plural or noun + 's'}"
