"""YAML as the package reads a file it did not write (a scenario, a vehicle, a bag's recorded scenario and
metadata): one line for what is wrong, a key given twice refused (YAML would keep the last one silently), and
limits that no hand-written file reaches: MAX_CHARACTERS of text, MAX_VALUES values once every alias is
expanded (a few hundred bytes of nested aliases expand to billions: the "billion laughs"), MAX_DEPTH levels."""
from __future__ import annotations

import yaml


MAX_CHARACTERS = 1 << 20   # a vehicle with its sources and a long scenario are a few kB
MAX_VALUES = 100_000       # scalars, lists and mappings, aliases expanded
MAX_DEPTH = 64             # nesting levels


class YamlError(ValueError):
    """Text that is not valid YAML; the message is one line naming where."""


class UniqueKeyLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):   # libyaml's parser: 10x faster
    """SafeLoader that refuses a mapping with the same key twice."""

    def construct_mapping(self, node, deep=False):
        """PyYAML's, refusing a key given twice in one mapping (ConstructorError at the second).

        Parameters
        ----------
        node : yaml.MappingNode
            The mapping's node.
        deep : bool
            PyYAML's: construct the values at once.

        Returns
        -------
        dict
            The mapping.
        """
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key!r}", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


def read_yaml(text: str, origin: str):
    """The object ``text`` holds; YamlError "ORIGIN: line N is not valid YAML (PROBLEM)" otherwise.

    Parameters
    ----------
    text : str
        The YAML text.
    origin : str
        Where it comes from, for the error.

    Returns
    -------
    object
        The object.
    """
    if len(text) > MAX_CHARACTERS:
        raise YamlError(f"{origin}: {len(text)} characters, more than the {MAX_CHARACTERS} a YAML file here may hold")
    loader = UniqueKeyLoader(text)
    try:
        node = loader.get_single_node()   # the node graph: an alias is a reference, cheap to hold
        if node is None:
            return None
        _check_size(node, origin)
        return loader.construct_document(node)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark else ""
        problem = " ".join(str(getattr(exc, "problem", None) or exc).split())   # one line, whatever YAML said
        raise YamlError(f"{origin}:{where} is not valid YAML ({problem})") from None
    except YamlError:
        raise
    except (ValueError, OverflowError) as exc:   # a value Python refuses to build, e.g. an int of 5000 digits
        raise YamlError(f"{origin}: a value that cannot be read ({' '.join(str(exc).split())[:120]})") from None
    finally:
        loader.dispose()


def read_yaml_file(path) -> object:
    """The object the YAML file ``path`` holds, read no further than the limit allows.

    Parameters
    ----------
    path : path-like
        The file.

    Returns
    -------
    object
        The object; YamlError when too large or not valid YAML, OSError or UnicodeDecodeError when unreadable.
    """
    with open(path, encoding="utf-8") as f:
        text = f.read(MAX_CHARACTERS + 1)   # a 50 MB file is not read whole to be refused
    return read_yaml(text, str(path))


def _check_size(root, origin: str):
    """Refuse a node graph deeper than MAX_DEPTH, holding more than MAX_VALUES values once its aliases are
    expanded, or an alias inside what it names (a value that contains itself)."""
    values, open_ = {}, set()

    def count(node, depth):
        if depth > MAX_DEPTH:
            raise YamlError(f"{origin}: nested more than {MAX_DEPTH} levels deep")
        key = id(node)
        if key in open_:
            raise YamlError(f"{origin}: line {node.start_mark.line + 1}: an alias inside the value it names")
        if key not in values:
            open_.add(key)
            children = (node.value if isinstance(node, yaml.SequenceNode) else
                        [n for pair in node.value for n in pair] if isinstance(node, yaml.MappingNode) else [])
            values[key] = 1 + sum(count(child, depth + 1) for child in children)
            open_.discard(key)
        if values[key] > MAX_VALUES:
            raise YamlError(f"{origin}: more than {MAX_VALUES} values once its aliases are expanded "
                            f"(line {node.start_mark.line + 1})")
        return values[key]
    count(root, 0)
