"""Reading a YAML file that may be hostile: bounded in size, nesting and expansion, strictly decoded,
with no key twice in a mapping, every error a ``TaskError`` naming the file or key path and line.

Used for task files and for a robot's limits file. Beyond ``yaml.safe_load`` it:

* opens regular files only (a device, pipe or folder is refused before any read) and reads at
  most ``MAX_FILE_BYTES``;
* decodes UTF-8 (byte-order mark optional) or UTF-16/UTF-32 with a byte-order mark, nothing else;
* refuses a key given twice in one mapping (YAML says keys are unique; PyYAML keeps the last),
  nesting deeper than ``MAX_NESTING``, recursive aliases, and documents expanding to more than
  ``MAX_VALUES`` values (an alias counts as everything it stands for: "billion laughs");
* resolves plain scalars by YAML 1.2's core schema (``_use_core_schema``): ``1e-4`` is a number
  (YAML 1.1, PyYAML's, reads a float without a dot as text, a trap for anyone writing small
  limits), ``010`` is ten, ``1:40`` is text, ``yes`` is text;
* refuses a number that no float holds (``1e-999``, ``1e999``), by its text and line, rather than
  reading it as 0.0 or infinity.

A plain text (``_LIBYAML_TEXT``) is parsed by libyaml, where PyYAML has it, under PyYAML's own composer,
constructor and resolver (the checks above): five times faster, the same data. Any other text, and any
text libyaml's parser refuses, is parsed by PyYAML's own, whose refusal the user sees.
"""

from __future__ import annotations

import codecs
import math
import os
import re
import stat
import sys
from pathlib import Path
from typing import Any, Callable

import yaml

from .errors import PlannerError, TaskError, shown

#: Largest file read [bytes]: 40 times a 1000-waypoint task (~100 kB). PyYAML's own parser
#: reads about 1 MB/s of dense values, so this also bounds the time spent reading.
MAX_FILE_BYTES = 4 * 2**20
#: Deepest nesting of lists and mappings (the task schema itself needs 4).
MAX_NESTING = 64
#: Most values (scalars, lists, mappings and keys) a file may expand to, an alias counting
#: as everything it stands for: a 1000-waypoint Cartesian task has about 26 000.
MAX_VALUES = 200_000
#: Byte-order marks a file may start with: (mark, Python codec, name in messages); UTF-32
#: first, as its little-endian mark starts with UTF-16's.
_BYTE_ORDER_MARKS = ((codecs.BOM_UTF32_LE, "utf-32", "UTF-32"), (codecs.BOM_UTF32_BE, "utf-32", "UTF-32"),
                     (codecs.BOM_UTF8, "utf-8-sig", "UTF-8"), (codecs.BOM_UTF16_LE, "utf-16", "UTF-16"),
                     (codecs.BOM_UTF16_BE, "utf-16", "UTF-16"))
_PLAIN_KEY = re.compile(r"[A-Za-z0-9_\-]{1,40}")


def _key_text(key) -> str:
    """A mapping key as a key-path component: plain short names as they are, YAML's null, true and false
    as YAML spells them (a key ``~:`` or ``true:``), anything else shown."""
    if key is None or isinstance(key, bool):
        return {None: "null", True: "true", False: "false"}[key]
    return key if isinstance(key, str) and _PLAIN_KEY.fullmatch(key) else shown(key, 40)


def key_path(path: str, key) -> str:
    """Key path of ``key`` in the mapping at ``path``."""
    return f"{path}.{_key_text(key)}" if path else _key_text(key)


def _child_path(path: str, index) -> str:
    """Key path of a YAML node under ``path``: ``index`` is its list position or its key's node."""
    if isinstance(index, int):
        return f"{path}[{index}]"
    return key_path(path, index.value if isinstance(index, yaml.ScalarNode) else "?")


#: The tag of the YAML merge key ``<<``.
_MERGE_TAG = "tag:yaml.org,2002:merge"


def _merged_keys(node: yaml.Node) -> list[yaml.Node]:
    """The scalar keys a mapping node gives, those of the mappings it merges (``<<``) included."""
    if not isinstance(node, yaml.MappingNode):
        return []
    keys = []
    for key, value in node.value:
        if key.tag == _MERGE_TAG:
            for merged in (value.value if isinstance(value, yaml.SequenceNode) else [value]):
                keys += _merged_keys(merged)
        elif isinstance(key, yaml.ScalarNode):
            keys.append(key)
    return keys


def _where(mark) -> str:
    """A YAML mark as ``line L, column C`` (both from 1)."""
    return f"line {mark.line + 1}, column {mark.column + 1}"


class _StrictComposing(yaml.composer.Composer, yaml.constructor.SafeConstructor):
    """What a strict loader adds to PyYAML's composer and constructor: it refuses, with a ``TaskError``
    naming the key path and line, a key twice in one mapping, nesting deeper than ``MAX_NESTING``,
    recursive aliases and documents expanding to more than ``MAX_VALUES`` values. A node its constructor
    cannot convert (``2001-13-45``, an integer of 5000 digits, ``1e999``) is a ``_KeyedConstructorError``
    naming the node's key path."""

    peek_event: Callable[[], Any]  # the parser's, PyYAML's or libyaml's (declared, not defined: not shadowed)
    check_event: Callable[..., bool]

    def _start(self) -> None:
        self._paths: list[str] = []         # key paths of the nodes being composed, outermost first
        self._sizes: dict[int, int] = {}    # id(node) -> values it expands to, once composed
        self._values = 0                    # values of the document so far, aliases expanded
        self._node_paths: dict[int, str] = {}  # id(node) -> its key path, where composed (not an alias)

    def _count(self, values: int, path: str, mark) -> None:
        self._values += values
        if self._values > MAX_VALUES:
            raise TaskError(path, f"the file expands to more than {MAX_VALUES} values by line {mark.line + 1} "
                                  f"(aliases count as everything they stand for)")

    def compose_node(self, parent, index):
        outer = self._paths[-1] if self._paths else ""
        path = outer if index is None else _child_path(outer, index)  # a key's path is its mapping's
        mark = self.peek_event().start_mark
        if self.check_event(yaml.AliasEvent):
            anchor = self.peek_event().anchor
            node = super().compose_node(parent, index)  # raises on an undefined alias
            if id(node) not in self._sizes:
                raise TaskError(path, f"alias *{shown(anchor, 40)} at line {mark.line + 1} refers to a list "
                                      f"or mapping containing it (recursive)")
            self._count(self._sizes[id(node)], path, mark)
            return node
        if len(self._paths) >= MAX_NESTING:
            raise TaskError(path, f"nested deeper than {MAX_NESTING} levels at line {mark.line + 1}")
        self._count(1, path, mark)
        event = self.peek_event()
        text = isinstance(event, yaml.ScalarEvent) and event.tag == "!"  # YAML 1.2's non-specific tag: text
        self._paths.append(path)
        try:
            node = super().compose_node(parent, index)
        finally:
            self._paths.pop()
        if isinstance(node, yaml.ScalarNode) and (text or (node.tag == _MERGE_TAG and index is not None)):
            node.tag = "tag:yaml.org,2002:str"  # (``! 60`` is "60"; ``<<`` merges only as a key)
        children = node.value if isinstance(node, yaml.SequenceNode) else \
            [child for pair in node.value for child in pair] if isinstance(node, yaml.MappingNode) else ()
        self._sizes[id(node)] = 1 + sum(self._sizes[id(child)] for child in children)
        self._node_paths[id(node)] = path
        return node

    def compose_mapping_node(self, anchor):
        node = super().compose_mapping_node(anchor)
        seen: dict[tuple[str, str], yaml.Node] = {}
        for key, _ in node.value:
            if not isinstance(key, yaml.ScalarNode):  # merge keys count too: two << would let the second win unseen
                continue
            earlier = seen.get((key.tag, key.value))
            if earlier is not None:  # an alias of an earlier key is that very node: compared by value, not identity
                merge = " (merge several mappings with one <<: [*a, *b])" if key.value == "<<" else ""
                where = (f"(an alias of the key at {_where(key.start_mark)})" if earlier is key else
                         f"at {_where(key.start_mark)} (first at {_where(earlier.start_mark)})")
                raise TaskError(_child_path(self._paths[-1], key),
                                f"duplicate key {where}; each key may appear once in a mapping{merge}")
            seen[(key.tag, key.value)] = key
        for key, value in node.value:
            if key.tag == _MERGE_TAG and isinstance(value, yaml.SequenceNode):
                self._refuse_merge_conflicts(value)
        return node

    def _refuse_merge_conflicts(self, merged: yaml.SequenceNode) -> None:
        """Refuse a key that two of the mappings merged by one ``<<: [*a, *b]`` both give: the YAML merge
        type lets the first win, PyYAML the last (a velocity limit 60 times lower than the file's reader
        expects), so which one holds would be a guess."""
        given: dict[tuple[str, str], yaml.Node] = {}
        for mapping in merged.value:
            for key in _merged_keys(mapping):
                earlier = given.get((key.tag, key.value))
                if earlier is not None and earlier is not key:
                    raise TaskError(_child_path(self._paths[-1], key),
                                    f"given by two mappings merged with << (at {_where(earlier.start_mark)} and "
                                    f"{_where(key.start_mark)}); merged mappings may not share a key: give it once, "
                                    f"or after the << (a key of the mapping itself overrides the merged ones)")
                given[(key.tag, key.value)] = key

    def construct_object(self, node, deep=False):
        try:
            return super().construct_object(node, deep)
        except (_KeyedConstructorError, PlannerError):
            raise
        except yaml.constructor.ConstructorError as exc:
            raise _KeyedConstructorError(self._node_paths.get(id(node), ""), exc.problem, exc.problem_mark) from None
        except (ValueError, TypeError, AttributeError, OverflowError, LookupError) as exc:
            # (PyYAML's own constructors raise KeyError for a !!bool it has no word for, IndexError for an
            # empty or sign-only !!float: their text is the value again, or an index, not a reason)
            kind = node.tag.rsplit(":", 1)[-1]
            reason = "" if isinstance(exc, LookupError) else f" ({shown(str(exc), 60)})"
            raise _KeyedConstructorError(self._node_paths.get(id(node), ""), f"cannot read {shown(node.value, 40)} as "
                                         f"{kind}{reason}", node.start_mark) from None


class _KeyedConstructorError(yaml.constructor.ConstructorError):
    """A node the constructor refused, with its key path (``""``: the document itself)."""

    def __init__(self, key_path: str, problem: str | None, mark):
        super().__init__(None, None, problem, mark)
        self.key_path = key_path


class _StrictLoader(_StrictComposing, yaml.SafeLoader):
    """``yaml.SafeLoader``, strict (``_StrictComposing``): the one whose refusals a file's reader sees."""

    def __init__(self, text: str):
        super().__init__(text)
        self._start()


#: Texts that ``_FastStrictLoader`` reads: printable ASCII and line ends, without tabs and without the
#: indicators of block scalars, tags, anchors, aliases, complex keys, directives and reserved characters. On
#: random documents libyaml and PyYAML read differently texts with tabs (libyaml accepts a trailing one),
#: byte-order marks inside the text (libyaml drops them, PyYAML keeps them in a key), block scalars whose header
#: runs into a comment, and ``>`` after a quoted scalar in a flow (libyaml accepts both); of 60 000 random
#: documents of the other characters, none.
_LIBYAML_TEXT = re.compile("[\n" + re.escape("".join(chr(c) for c in range(0x20, 0x7F) if chr(c) not in "|>!&*?%@`"))
                           + "]*")

if yaml.__with_libyaml__:
    class _FastStrictLoader(_StrictComposing, yaml.resolver.Resolver, yaml.cyaml.CParser):
        """``_StrictLoader`` with libyaml's parser under PyYAML's own composer, constructor and resolver: the
        same checks and data on the texts it takes (``_LIBYAML_TEXT``), parsed 5 times faster (a task of 1024
        joint via-points: 0.05 s, not 0.24 s). ``_parse_yaml`` leaves refusals to ``_StrictLoader``: libyaml
        words its errors, and places them in bytes, differently."""

        def __init__(self, text: str):
            yaml.cyaml.CParser.__init__(self, text)
            yaml.composer.Composer.__init__(self)
            yaml.constructor.SafeConstructor.__init__(self)
            yaml.resolver.Resolver.__init__(self)
            self._start()


def _read_bytes(path: Path, what: str) -> bytes:
    """The bytes of a regular file of at most ``MAX_FILE_BYTES`` (a device, pipe or folder is refused
    before anything is read; the read itself is bounded)."""
    try:
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except (OSError, ValueError) as exc:  # ValueError: a NUL character in the path
        raise TaskError(str(path), f"cannot read {what} ({getattr(exc, 'strerror', None) or exc})") from None
    if not stat.S_ISREG(os.fstat(descriptor).st_mode):
        os.close(descriptor)
        raise TaskError(str(path), f"cannot read {what} (not a regular file: a folder, device or pipe)")
    with os.fdopen(descriptor, "rb") as file:
        try:
            raw = file.read(MAX_FILE_BYTES + 1)
        except OSError as exc:
            raise TaskError(str(path), f"cannot read {what} ({exc.strerror or exc})") from None
    if len(raw) > MAX_FILE_BYTES:
        raise TaskError(str(path), f"{what} larger than {MAX_FILE_BYTES} bytes ({MAX_FILE_BYTES >> 20} MiB)")
    return raw


def _decode(raw: bytes, path: Path, what: str) -> str:
    """Text of a file: UTF-8 (byte-order mark optional) or UTF-16/UTF-32 with a byte-order mark."""
    codec, encoding = next(((codec, name) for mark, codec, name in _BYTE_ORDER_MARKS if raw.startswith(mark)),
                           ("utf-8", "UTF-8"))
    try:
        return raw.decode(codec)
    except UnicodeDecodeError as exc:
        raise TaskError(str(path), f"not valid {encoding} at byte {exc.start} ({exc.reason}); {what}s are "
                                   f"UTF-8, or UTF-16/UTF-32 with a byte-order mark") from None


def _parse_yaml(text: str, path: Path):
    """The plain data of one YAML document (see ``_StrictComposing`` for what is refused): read with libyaml's
    parser where PyYAML has it and the text is one both read alike (``_LIBYAML_TEXT``), else, or where that
    fails (for its refusal), with PyYAML's own."""
    if yaml.__with_libyaml__ and _LIBYAML_TEXT.fullmatch(text):
        fast = None
        try:
            fast = _FastStrictLoader(text)
            return fast.get_single_data()
        except (yaml.YAMLError, PlannerError):
            pass
        finally:
            if fast is not None:
                fast.dispose()
    loader = None
    try:
        loader = _StrictLoader(text)  # checks every character first
        return loader.get_single_data()
    except yaml.reader.ReaderError as exc:  # a character YAML does not allow, found before parsing
        line = text.count("\n", 0, exc.position) + 1
        column = exc.position - text.rfind("\n", 0, exc.position)
        hint = " (a NUL: is the file UTF-16 without a byte-order mark?)" if exc.character in ("\0", 0) else ""
        code = exc.character if isinstance(exc.character, int) else ord(exc.character)
        raise TaskError(str(path), f"control character U+{code:04X} at line {line}, column {column} is not "
                                   f"allowed in YAML{hint}") from None
    except yaml.YAMLError as exc:  # named by the key path of the node it refused, where there is one
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise TaskError(getattr(exc, "key_path", "") or str(path),
                        f"not valid YAML{where}: {getattr(exc, 'problem', None) or exc}") from None
    finally:
        if loader is not None:
            loader.dispose()


def _use_core_schema(loader: type[yaml.SafeLoader]) -> None:
    """Plain scalars resolved as YAML 1.2's core schema does, not as YAML 1.1 (PyYAML's): ``1e-4`` is
    a number, while ``017`` is 17 (not octal 15), ``1:40`` and ``2001-12-14`` are text (not 100 and a
    date), and only ``true``/``false`` are booleans (``yes``, ``no``, ``on``, ``off`` are text)."""
    core = {"bool": r"true|True|TRUE|false|False|FALSE",
            "int": r"[-+]?[0-9]+(_[0-9]+)*|0o[0-7]+|0x[0-9a-fA-F]+",  # 1_000 too, as in Python
            # 1_000.5 and 1e1_0 too, as in Python: underscores between digits
            "float": r"[-+]?(\.D|D(\.(D)?)?)([eE][-+]?D)?|[-+]?\.(inf|Inf|INF)|\.(nan|NaN|NAN)".replace(
                "D", "[0-9]+(_[0-9]+)*"),
            "null": r"~|null|Null|NULL|"}
    replaced = {f"tag:yaml.org,2002:{name}" for name in (*core, "timestamp", "value")}  # (YAML 1.1's "=")
    loader.yaml_implicit_resolvers = {first: [(tag, rule) for tag, rule in rules if tag not in replaced]
                                      for first, rules in yaml.SafeLoader.yaml_implicit_resolvers.items()}
    for name, pattern in core.items():
        starts = list("tTfF") if name == "bool" else list("~nN") + [""] if name == "null" else list("-+.0123456789")
        loader.add_implicit_resolver(f"tag:yaml.org,2002:{name}", re.compile(f"^(?:{pattern})$"), starts)
    loader.add_constructor("tag:yaml.org,2002:int", _core_int)
    loader.add_constructor("tag:yaml.org,2002:float", _core_float)


def _core_int(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> int:
    """A core-schema integer: decimal (leading zeros allowed), ``0o`` octal or ``0x`` hexadecimal."""
    text = loader.construct_scalar(node).replace("_", "")
    base = {"0o": 8, "0x": 16}.get(text[:2], 10)
    return int(text[2:] if base != 10 else text, base)


def _core_float(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> float:
    """A core-schema float; a number written with digits that no float holds is refused (``1e-999``
    would read as 0.0 and ``1e999`` as infinity, and a message would then quote a value the file does
    not hold).

    Raises:
        yaml.constructor.ConstructorError: naming the text, its line and the float's range.
    """
    value = yaml.SafeLoader.construct_yaml_float(loader, node)
    text = node.value.lower()
    if math.isinf(value) and "inf" not in text:
        problem = f"overflows to infinity (the largest float is {sys.float_info.max:.3g})"
    elif value == 0.0 and re.search("[1-9]", text.split("e")[0]):
        problem = f"underflows to 0.0 (the smallest float is {math.ulp(0.0):.3g})"
    else:
        return value
    raise yaml.constructor.ConstructorError(None, None, f"cannot read {shown(node.value, 40)} as a number: it "
                                                        f"{problem}", node.start_mark)


_use_core_schema(_StrictLoader)
if yaml.__with_libyaml__:
    _use_core_schema(_FastStrictLoader)


def read_yaml(path, what: str = "YAML file"):
    """The plain data of the one YAML document in the file at ``path`` (see the module docstring).

    Args:
        path: the file's path.
        what: what the file is, for messages ("task file", "limits file").

    Raises:
        TaskError: naming the file (or the key path) and what is wrong with it.
    """
    path = Path(path)
    return _parse_yaml(_decode(_read_bytes(path, what), path, what), path)
