"""YAML files read with their line numbers, so that a bad entry is reported as ``file:line``.

    data = yamlfile.load("hotspots.yaml")        # YamlError("hotspots.yaml:3: ...") on a syntax error
    spots = data["hotspots"]                      # a LineDict: a dict that knows its lines
    line = spots.line_of("kitchen")               # 1-based line of the entry "kitchen"
    raise yamlfile.YamlError(path, line, "x must be a number")

Mappings load as :class:`LineDict` and sequences as :class:`LineList` (a dict and a list with
``line`` of their own start and ``line_of(key_or_index)`` of each entry); scalars are the usual
Python values. Only YAML's safe types are built (``yaml.SafeLoader``, libyaml's when installed).
"""

import yaml


class YamlError(ValueError):
    """A file that cannot be used: the message starts with ``path:line:``."""

    def __init__(self, path, line, problem):
        where = f"{path}:{line}" if line else str(path)
        super().__init__(f"{where}: {problem}")
        self.path, self.line, self.problem = str(path), line, problem


class LineDict(dict):
    line = 0
    lines = None

    def line_of(self, key):
        """1-based line of entry ``key`` (its key), or the mapping's own line."""
        return (self.lines or {}).get(key, self.line)


class LineList(list):
    line = 0
    lines = None

    def line_of(self, index):
        """1-based line of item ``index``, or the sequence's own line."""
        lines = self.lines or []
        return lines[index] if 0 <= index < len(lines) else self.line


def line_of(container, key):
    """Line of ``key`` in ``container`` when it came from :func:`load`, else 0 (unknown)."""
    finder = getattr(container, "line_of", None)
    return finder(key) if finder is not None else 0


class _Loader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # libyaml's parser where it is installed
    pass


def _mapping(loader, node):
    out = LineDict()
    out.line, out.lines = node.start_mark.line + 1, {}
    loader.flatten_mapping(node)
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        try:
            hash(key)
        except TypeError:
            raise yaml.constructor.ConstructorError(None, None, "a mapping key must be a plain value",
                                                    key_node.start_mark) from None
        if key in out:
            raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key!r}", key_node.start_mark)
        out[key] = loader.construct_object(value_node, deep=True)
        out.lines[key] = key_node.start_mark.line + 1
    return out


def _sequence(loader, node):
    out = LineList(loader.construct_object(child, deep=True) for child in node.value)
    out.line, out.lines = node.start_mark.line + 1, [child.start_mark.line + 1 for child in node.value]
    return out


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping)
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _sequence)


def loads(text, path="<string>"):
    """The YAML document ``text`` with line numbers; YamlError naming ``path`` and the line."""
    try:
        return yaml.load(text, Loader=_Loader)  # _Loader is a SafeLoader
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark is not None else 0
        raise YamlError(path, line, f"not valid YAML: {exc.problem or exc.context}") from None
    except yaml.YAMLError as exc:
        raise YamlError(path, 0, f"not valid YAML: {exc}") from None


def load(path):
    """The YAML file ``path`` with line numbers (see the module docstring). YamlError for a file
    that cannot be read or parsed, naming the file (and the line where YAML knows it)."""
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except (OSError, UnicodeDecodeError) as exc:
        raise YamlError(path, 0, f"cannot be read: {exc}") from None
    return loads(text, str(path))
