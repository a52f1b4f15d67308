"""YAML as the package reads a user's file (a scenario, a vehicle): one line for what is wrong, and a key
given twice refused (YAML would keep the last one silently)."""
from __future__ import annotations

import yaml


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
    try:
        return yaml.load(text, Loader=UniqueKeyLoader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark else ""
        problem = " ".join(str(getattr(exc, "problem", None) or exc).split())   # one line, whatever YAML said
        raise YamlError(f"{origin}:{where} is not valid YAML ({problem})") from None
