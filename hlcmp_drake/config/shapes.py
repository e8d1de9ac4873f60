"""Where a YAML file's value does not fit the type its field declares: a list where a number
goes, a number where a list goes, text where a number goes. Drake's typed loader says so
without the line, and of a scalar given for a list often only "'float' object is not
iterable"; this finds the value, its line and its dotted key, so that the error names
them; and of text where a list of numbers goes, which it reads as one number a character
("300" as [3, 0, 0]), that it is no list at all."""

from __future__ import annotations

import dataclasses as dc
import difflib
import functools
import types
import typing
from typing import Union

import yaml
from pydrake.common import pretty_class_name

_NUMBER_TAGS = {"tag:yaml.org,2002:int", "tag:yaml.org,2002:float"}
_NULL_TAG = "tag:yaml.org,2002:null"
_STR_TAG = "tag:yaml.org,2002:str"
_BOOL_TAG = "tag:yaml.org,2002:bool"
_MERGE_TAG = "tag:yaml.org,2002:merge"  # a `<<: *anchor` key: the anchor's fields, not one


# libyaml's parser where PyYAML was built with it: the same nodes, ten times as fast.
_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


@functools.lru_cache(maxsize=64)  # the loaders read the same few files many times
def composed(text: str) -> yaml.Node | None:
    """A YAML text's node tree (each node with its line), or None when the text is empty
    or does not parse (the loaders' own messages say where).

    Parameters
    ----------
    text : str

    Returns
    -------
    yaml.Node or None
        Shared between callers: not to be changed.
    """
    try:
        return yaml.compose(text, Loader=_LOADER)
    except yaml.YAMLError:
        return None


@functools.lru_cache(maxsize=64)
def misshapen_value(
    text: str, schema: type, skip: tuple[str, ...] = ()
) -> tuple[int, str, str] | None:
    """The first value of a YAML text whose shape does not fit its field's type.

    Checked: the fields of a dataclass or of a Drake schema class (MultibodyPlantConfig,
    the model directives; a tagged union's member by its tag; a key that is none of its
    fields, with the nearest one), lists, maps, numbers (an int field takes only an int)
    and text. Fields of other types (arrays, say) are left to the typed loader.

    Parameters
    ----------
    text : str
        The YAML text.
    schema : type
        The dataclass it is read into, e.g. `Scenario`.
    skip : tuple of str
        Top-level keys not to check (a sweep's sections that are rewritten before they
        are read).

    Returns
    -------
    (int, str, str) or None
        The value's line (from 1), its dotted key (list items by index) and what is wrong
        (e.g. "must be a list, got 2000.0"); None when every value fits or the text does not
        parse as YAML.
    """
    root = composed(text)
    if skip and isinstance(root, yaml.MappingNode):  # a new node: the cached one is shared
        kept = [
            (k, v)
            for k, v in root.value
            if not (isinstance(k, yaml.ScalarNode) and k.value in skip)
        ]
        root = yaml.MappingNode(root.tag, kept, root.start_mark, root.end_mark)
    return None if root is None else _check(root, schema, "", set())


def _check(
    node: yaml.Node, hint: typing.Any, key: str, visited: set[int], chosen_by_tag: bool = False
) -> tuple[int, str, str] | None:
    # An alias is the node it names: each node is checked once, so that an alias within
    # itself ends and aliases of aliases do not multiply the work.
    if id(node) in visited:
        return None
    visited.add(id(node))

    def wrong(expected: str) -> tuple[int, str, str]:
        return node.start_mark.line + 1, key, f"must be {expected}, got {_shown(node)}"

    origin = typing.get_origin(hint)
    if origin in (Union, types.UnionType):
        members = [a for a in typing.get_args(hint) if a is not type(None)]
        if len(members) < len(typing.get_args(hint)) and node.tag == _NULL_TAG:
            return None  # an optional field left empty
        visited.discard(id(node))  # the same node again, as the member it holds
        if len(members) == 1:
            return _check(node, members[0], key, visited)
        tags = [f"!{_tag_name(m)}" for m in members]
        if node.tag in tags:
            return _check(node, members[tags.index(node.tag)], key, visited, chosen_by_tag=True)
        if node.tag.startswith("!"):
            near = difflib.get_close_matches(node.tag, tags, n=1)
            hint = f" (did you mean {near[0]}?)" if near else ""
            return (
                node.start_mark.line + 1,
                key,
                f"{node.tag} is none of {', '.join(tags)}{hint}",
            )
        if all(dc.is_dataclass(m) for m in members):
            if not isinstance(node, yaml.MappingNode):
                return wrong("a map of fields")
            return _untagged(node, members, key, visited)
        return None
    fields = _fields_of(hint)
    if fields is not None:
        if not isinstance(node, yaml.MappingNode):
            return wrong("a map of fields")
        schema_name = getattr(hint, "__name__", hint)
        if node.tag.startswith("!") and not chosen_by_tag:  # Drake: "The fields ['_tag'] ..."
            return (
                node.start_mark.line + 1,
                key,
                f"takes no tag ({node.tag}): it holds a {schema_name} only; give its fields alone",
            )
        for name, value in node.value:
            if not isinstance(name, yaml.ScalarNode) or name.tag == _MERGE_TAG:
                continue
            if not key and str(name.value).startswith("_"):
                continue  # Drake's loader ignores a document's `_` keys: a place for anchors
            if name.value not in fields:
                # Drake's loader would say only "The fields [...] were unknown to the schema".
                near = difflib.get_close_matches(name.value, list(fields), n=1)
                return (
                    name.start_mark.line + 1,
                    _join(key, name.value),
                    f"no such field in {schema_name}"
                    + (f" (did you mean '{near[0]}'?)" if near else ""),
                )
            found = _check(value, fields[name.value], _join(key, name.value), visited)
            if found:
                return found
        return None
    if origin is list:
        if not isinstance(node, yaml.SequenceNode):
            return wrong("a list")
        (item,) = typing.get_args(hint)
        for index, value in enumerate(node.value):
            found = _check(value, item, _join(key, str(index)), visited)
            if found:
                return found
        return None
    if origin is dict:
        if not isinstance(node, yaml.MappingNode):
            return wrong("a map")
        _, item = typing.get_args(hint)
        for name, value in node.value:
            if isinstance(name, yaml.ScalarNode) and name.tag == _MERGE_TAG:
                continue  # `<<: *anchor`: the anchor's entries, left as a schema's are
            found = _check(value, item, _join(key, str(name.value)), visited)
            if found:
                return found
        return None
    if hint in (float, int, str, bool) and not isinstance(node, yaml.ScalarNode):
        return wrong(
            {float: "a number", int: "an integer", str: "text", bool: "true or false"}[hint]
        )
    if hint is float and not _reads_as(float, node):
        return wrong("a number")
    if hint is int and not _reads_as(int, node):
        # Drake reads text as an integer by Python's int(): 1e3 is a number, but not so.
        return wrong("an integer" + " in digits" * _whole_as_text(node))
    # Drake takes only text for text (an empty value is none), and for true or false only
    # YAML's booleans or the words true and false.
    if hint is str and node.tag != _STR_TAG:
        return wrong("text")
    if hint is bool and not (
        node.tag == _BOOL_TAG or (node.tag == _STR_TAG and node.value in ("true", "false"))
    ):
        return wrong("true or false")
    return None


def _tag_name(member: typing.Any) -> str:
    """The tag that picks `member` of a union, as Drake's loader matches it: the class's name,
    a template's without its arguments (DeterministicVector for DeterministicVector[3],
    whose own __name__ is 'DeterministicVector𝓣3𝓤')."""
    if not isinstance(member, type):
        return getattr(member, "__name__", "")
    return pretty_class_name(member).split("[", 1)[0]


def _fields_of(hint: typing.Any) -> dict[str, typing.Any] | None:
    """A schema's fields and their types: a dataclass's, or a Drake schema class's (the
    `__fields__` that pydrake's YAML loader reads, e.g. MultibodyPlantConfig's); None for
    any other type."""
    if dc.is_dataclass(hint):
        return typing.get_type_hints(hint)
    fields = getattr(hint, "__fields__", None) if isinstance(hint, type) else None
    if isinstance(fields, tuple) and all(hasattr(f, "name") and hasattr(f, "type") for f in fields):
        return {f.name: f.type for f in fields}
    return None


def _untagged(
    node: yaml.MappingNode, members: list, key: str, visited: set[int]
) -> tuple[int, str, str] | None:
    """An untagged map for a tagged union: Drake reads it as the union's first member, so
    its fields are checked as that member's; a field only another member has names the
    tag the map was most likely meant to carry (Drake would say only "The fields [...]
    were unknown to the schema")."""
    first = members[0]
    keys = [
        name
        for name, _ in node.value
        if isinstance(name, yaml.ScalarNode) and name.tag != _MERGE_TAG
    ]
    names = [name.value for name in keys]
    unknown = [name for name in names if name not in typing.get_type_hints(first)]
    if unknown:
        holding = [
            member
            for member in members[1:]
            if all(name in typing.get_type_hints(member) for name in names)
        ]
        # The most general of them (a pose config holds its translational one's fields).
        owners = [
            f"!{m.__name__}"
            for m in holding
            if not any(m is not o and issubclass(m, o) for o in holding)
        ]
        if len(owners) == 1:
            whose = f"they are {owners[0]}'s: give its tag"
        else:
            whose = "give the tag of the config whose they are" + (
                f" ({' or '.join(owners)})" if owners else ""
            )
        shown = ", ".join(map(repr, unknown[:3])) + ", ..." * (len(unknown) > 3)
        fields = "field" + "s" * (len(unknown) > 1)
        return (
            keys[names.index(unknown[0])].start_mark.line + 1,
            key,
            f"untagged, so read as !{first.__name__}, which has no {fields} {shown}: {whose}",
        )
    visited.discard(id(node))  # the same node again, as the member it is read as
    return _check(node, first, key, visited)


def _reads_as(kind: type, node: yaml.ScalarNode) -> bool:
    """Whether a scalar is a number of `kind`: YAML's own (.nan, .inf, 0x1f), or text that
    Python reads so (1e-3, which YAML 1.1 reads as text); an integer may be written as a
    whole float (10.0), as Drake's loader reads it, but not as text that Python's int()
    does not read (1e3)."""
    if node.tag == "tag:yaml.org,2002:int" or (kind is float and node.tag in _NUMBER_TAGS):
        return True
    try:
        if node.tag in _NUMBER_TAGS:  # a float for an int
            return float(yaml.safe_load(node.value)).is_integer()
        kind(node.value)  # text, read as Drake reads it
    except (ValueError, TypeError, yaml.YAMLError):
        return False
    return True


def _whole_as_text(node: yaml.ScalarNode) -> bool:
    """Whether a scalar is text that Python reads as a whole number (1e3), but int() not."""
    return node.tag == _STR_TAG and _reads_as(float, node) and float(node.value).is_integer()


def _join(key: str, part: str) -> str:
    return f"{key}.{part}" if key else part


def _shown(node: yaml.Node) -> str:
    """A value as the message shows it: a scalar as written, else its kind."""
    if isinstance(node, yaml.ScalarNode):
        if node.tag == _NULL_TAG:
            return "nothing"
        return repr(node.value) if node.tag == "tag:yaml.org,2002:str" else node.value
    return "a list" if isinstance(node, yaml.SequenceNode) else "a map"
