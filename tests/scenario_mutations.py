"""Mutations of the default scenario file, for the property tests (config) and the CLI tests.

:func:`mutated` draws TOML bytes of the embedded default scenario with keys deleted, values replaced by
other types, extreme and non-finite numbers, deep nesting, long arrays and strings, other text
encodings and corrupted bytes.
"""

import copy
import math
import tomllib
from importlib import resources

import tomli_w
from hypothesis import strategies as st

__all__ = ["BASE", "mutated"]

BASE = tomllib.loads((resources.files("postcapture.config") / "scenarios" / "envisat.toml").read_text())


def _get(node, path):
    for key in path:
        node = node[key]
    return node


def _paths(node, prefix=()):
    """Every path (tuple of keys and indices) into a nested dict/list, the root excluded."""
    out = []
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, child in items:
        out.append(prefix + (key,))
        out += _paths(child, prefix + (key,))
    return out


PATHS = _paths(BASE)
LEAVES = [p for p in PATHS if isinstance(_get(BASE, p), (int, float)) and not isinstance(_get(BASE, p), bool)]

numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e308, -1e308, 5e-324, 1e-300, 1e300, math.inf, -math.inf, math.nan]),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.sampled_from([2**63, -(2**63) - 1, 10**30, 0, -1, 1]),
)
text = st.one_of(
    st.text(max_size=30),
    st.sampled_from(["", "joint_\u0663", "joint_\uff11", "joint_0", "joint_01", "joint_7", "force_q", "1e3",
                     "true", "\x00", "../../etc/passwd", "x" * 5000]),
)
scalars = st.one_of(st.booleans(), numbers, text)
values = st.recursive(
    scalars,
    lambda children: st.one_of(st.lists(children, max_size=4), st.dictionaries(st.text(max_size=8), children, max_size=3)),
    max_leaves=12,
)


def _nested(depth: int, leaf):
    out = leaf
    for _ in range(depth):
        out = [out]
    return out


@st.composite
def mutated(draw):
    """TOML bytes of a mutated default scenario."""
    data = copy.deepcopy(BASE)
    deep = None
    for _ in range(draw(st.integers(1, 4))):
        action = draw(st.sampled_from(["delete", "replace", "nest", "grow", "huge", "huge"]))
        path = draw(st.sampled_from(LEAVES if action == "huge" else PATHS))
        parent = data
        try:
            for key in path[:-1]:
                parent = parent[key]
            if not isinstance(parent, (dict, list)):
                raise TypeError
            parent[path[-1]]
        except (KeyError, IndexError, TypeError):
            continue  # an earlier mutation removed or replaced this branch
        if action == "delete":
            if isinstance(parent, dict):
                del parent[path[-1]]
            else:
                parent.pop(path[-1])
        elif action == "replace":
            parent[path[-1]] = draw(values)
        elif action == "nest":
            depth = draw(st.sampled_from([1, 2, 5, 50, 200, 400, 1000, 5000]))
            if depth <= 50:
                parent[path[-1]] = _nested(depth, parent[path[-1]])
            else:  # deeper than the TOML writer goes: spliced into the text below
                parent[path[-1]], deep = "@@deep@@", depth
        elif action == "grow":
            parent[path[-1]] = [draw(scalars)] * draw(st.integers(0, 20_000))
        else:
            parent[path[-1]] = draw(st.sampled_from([1e308, -1e308, 2**64, 1e-320, 1e150, 1e200, math.nan, math.inf]))
    try:
        raw = tomli_w.dumps(data).encode()
    except (TypeError, ValueError, RecursionError):
        raw = repr(data).encode()  # not TOML at all: must be refused as such
    if deep is not None:
        raw = raw.replace(b'"@@deep@@"', b"[" * deep + b"1" + b"]" * deep)
    encoding = draw(st.sampled_from(["utf-8", "utf-8", "utf-8", "bom", "utf-16", "latin-1", "flip", "cut"]))
    if encoding == "bom":
        raw = b"\xef\xbb\xbf" + raw
    elif encoding == "utf-16":
        raw = raw.decode().encode("utf-16")
    elif encoding == "latin-1":
        raw = raw.decode().encode("latin-1", errors="replace") + b"\n# caf\xe9\n"
    elif encoding == "flip" and raw:
        i = draw(st.integers(0, len(raw) - 1))
        raw = raw[:i] + bytes([draw(st.integers(0, 255))]) + raw[i + 1:]
    elif encoding == "cut" and raw:
        raw = raw[: draw(st.integers(0, len(raw) - 1))]
    return raw
