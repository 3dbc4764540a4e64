"""The part of CSS an SVG reader needs to know what is drawn: `<style>` sheets whose rules
set paint and visibility through simple selectors.

Selectors: type (`path`), universal (`*`), class (`.a`), id (`#a`) and their compounds
(`path.a.b#c`), joined by descendant (` `) and child (`>`) combinators, in
comma-separated lists. A selector of another kind (attribute selectors, pseudo-classes
such as `:hover`, sibling combinators) matches nothing; a rule with a malformed selector
(a trailing comma, a leading combinator) is dropped whole, as CSS drops it. Conditional
at-rules (`@media`, `@supports`) and `@import` are not applied, nor are sheets for
another medium (`<style media="print">`) or language (`type` other than `text/css`): the
drawing read is what a screen shows by default. The cascade (CSS 2.1, 6.4): presentation
attributes, then sheet rules by specificity and order, then the `style` attribute, then
`!important` sheet declarations, then `!important` `style` declarations.

Rules are matched once per element of the document tree (`cascade`), so an element drawn
by several `<use>`s is styled where it stands in the document, as SVG 1.1 (5.6)
requires, and the cost is linear in the elements and the selectors' steps.
"""

import re


_COMMENT = re.compile(r"/\*.*?(?:\*/|$)", re.S)
_SPECIAL = re.compile(r"""[{}"';\\]""")
_COMPOUND = re.compile(r"(\*|[A-Za-z_][\w-]*)?((?:[.#][A-Za-z_-][\w-]*)*)$")
_SUPPORTED_PART = re.compile(r"[\w.#*-]+$")
_STRING_END = {q: re.compile(rf"(?:\\.|[^{q}\\])*{q}?", re.S) for q in "\"'"}


def local_name(tag) -> str:
    """An element's tag without its namespace ('' for comments and processing
    instructions)."""
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""


def _blocks(text: str):
    """`(prelude, body)` of each top-level rule, at-rules included, in order. Quoted
    strings and escapes are skipped; a block still open at the end closes there."""
    i, prelude_start, depth, body_start = 0, 0, 0, 0
    while True:
        match = _SPECIAL.search(text, i)
        if match is None:
            if depth:
                yield text[prelude_start:body_start - 1].strip(), text[body_start:]
            return
        c, i = match.group(), match.end()
        if c == "\\":
            i += 1
        elif c in "\"'":
            i = _STRING_END[c].match(text, i).end()
        elif c == "{":
            depth += 1
            if depth == 1:
                body_start = i
        elif c == "}" and depth:
            depth -= 1
            if depth == 0:
                yield text[prelude_start:body_start - 1].strip(), text[body_start:i - 1]
                prelude_start = i
        elif c == ";" and depth == 0:
            prelude_start = i  # `@import ...;`, `@charset ...;`


def declarations(body: str) -> dict:
    """`name: value` declarations, lower case, as {name: (value, important)}."""
    found = {}
    for declaration in body.split(";"):
        name, colon, value = declaration.partition(":")
        if colon:
            value = value.strip().lower()
            important = re.search(r"!\s*important\s*$", value)
            if important:
                value = value[: important.start()].strip()
            found[name.strip().lower()] = (value, important is not None)
    return found


def _selector(text: str):
    """A selector as a list of steps (combinator, tag, classes, id) from left to right and
    its specificity (ids, classes, types); "unsupported" for a valid selector that is
    not supported here, None for a malformed one."""
    parts = [p for p in re.split(r"\s*(>)\s*|\s+", text.strip()) if p]
    if not parts or parts[0] == ">" or parts[-1] == ">":
        return None
    steps, combinator, specificity = [], " ", [0, 0, 0]
    for part in parts:
        if part == ">":
            if combinator == ">":
                return None
            combinator = ">"
            continue
        if not _SUPPORTED_PART.match(part):
            return "unsupported"  # `:hover`, `[d]`, `+`, `~`, ...
        match = _COMPOUND.match(part)
        if match is None:
            return None
        tag, rest = match.group(1), match.group(2)
        classes = frozenset(re.findall(r"\.([\w-]+)", rest))
        ids = set(re.findall(r"#([\w-]+)", rest))
        if len(ids) > 1:
            return "unsupported"  # two ids: matches nothing
        specificity[0] += len(ids)
        specificity[1] += len(classes)
        specificity[2] += 1 if tag and tag != "*" else 0
        steps.append((combinator, None if tag in (None, "*") else tag, classes, next(iter(ids), None)))
        combinator = " "
    return steps, tuple(specificity)


def parse_sheets(sheets: list[str]) -> list:
    """The supported rules of the style sheets' texts, in cascade order (lowest first):
    a list of (steps, declarations)."""
    rules, order = [], 0
    for text in sheets:
        for prelude, body in _blocks(_COMMENT.sub("", text)):
            if prelude.startswith("@"):
                continue
            selectors = [_selector(s) for s in prelude.split(",")]
            if None in selectors:
                continue  # a malformed selector drops the whole rule
            found = declarations(body)
            for selector in selectors:
                if selector != "unsupported" and found:
                    rules.append((selector[1], order, selector[0], found))
                    order += 1
    rules.sort(key=lambda rule: (rule[0], rule[1]))
    return [(steps, found) for _, _, steps, found in rules]


def applies(element) -> bool:
    """Whether a `<style>` element's sheet applies to the screen rendering."""
    kind = (element.get("type") or "text/css").strip().lower()
    media = {m.strip().lower() for m in (element.get("media") or "all").split(",")}
    return kind == "text/css" and bool(media & {"all", "screen", ""})


def _one(step, element, tag: str) -> bool:
    _, want, classes, id_ = step
    if want is not None and want != tag:
        return False
    if classes and not classes <= set((element.get("class") or "").split()):
        return False
    return id_ is None or element.get("id") == id_


def cascade(root, rules: list) -> dict:
    """The sheet declarations that apply to each element under `root` that any rule
    matches: {element: {name: (value, important)}}, later rules overriding earlier ones.

    One walk down the tree carries, for each element, which selector steps it matches
    (`matched`: the step matches it and the steps before it match above it as their
    combinators require) and which steps it or an ancestor matches (`below`): a child
    combinator looks at its parent's `matched`, a descendant one at its parent's
    `below`."""
    if not rules:
        return {}
    index: dict = {}
    for r, (steps, _) in enumerate(rules):
        for j, step in enumerate(steps):
            _, tag, classes, id_ = step
            key = ("#", id_) if id_ else (".", next(iter(classes))) if classes else ("", tag)
            index.setdefault(key, []).append((r, j))
    styled = {}
    stack = [(root, frozenset(), frozenset())]
    while stack:
        element, parent_matched, parent_below = stack.pop()
        tag = local_name(element.tag)
        candidates = [*index.get(("", None), ()), *index.get(("", tag), ()),
                      *index.get(("#", element.get("id")), ())]
        for c in (element.get("class") or "").split():
            candidates += index.get((".", c), ())
        matched = set()
        for r, j in candidates:
            steps = rules[r][0]
            if not _one(steps[j], element, tag):
                continue
            if j == 0 or (r, j - 1) in (parent_matched if steps[j][0] == ">" else parent_below):
                matched.add((r, j))
        found = {}
        for r in sorted(r for r, j in matched if j == len(rules[r][0]) - 1):
            found.update(rules[r][1])
        if found:
            styled[element] = found
        below = parent_below | matched if matched else parent_below
        matched = frozenset(matched)
        stack.extend((child, matched, below) for child in element)
    return styled
