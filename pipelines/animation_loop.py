"""How an animation output plays: once, repeated, or there and back (``--loop``).

One definition for the CLI (``morph2d --loop``), the API (``loop`` of ``POST
/v1/morphs2d``), the Python client and the batch manifest (``loop``). It
imports nothing heavy, so ``conformorph --help`` and the service can read it.

* ``"once"`` (the default): play from the first frame to the last and stay on
  the last (SMIL ``fill="freeze"``);
* ``"repeat"``: play first to last, again and again;
* ``"alternate"``: first to last and back to the first, again and again (the
  frames mirrored, so the turn shows no jump).
"""

from __future__ import annotations

#: The accepted values of ``loop``, the default first.
LOOP_MODES = ("once", "repeat", "alternate")
#: The default of ``loop``: play once and hold the last frame.
DEFAULT_LOOP = "once"


def check_loop(loop: str) -> str:
    """``loop`` itself when it is one of :data:`LOOP_MODES`.

    Parameters
    ----------
    loop : str

    Returns
    -------
    str

    Raises
    ------
    ValueError
        Any other value, naming the accepted ones.
    """
    if loop not in LOOP_MODES:
        raise ValueError(f"loop must be one of {', '.join(LOOP_MODES)}; got {loop!r}")
    return loop
