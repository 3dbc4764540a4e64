"""The part of CSS an SVG reader needs to know what is drawn: `<style>` sheets whose rules
set paint and visibility through simple selectors.

Selectors: type (`path`), universal (`*`), class (`.a`), id (`#a`) and their compounds
(`path.a.b#c`), joined by descendant (` `) and child (`>`) combinators, in
comma-separated lists. Rules with any other selector (attribute selectors, pseudo-classes
such as `:hover`, sibling combinators) are not applied, and neither are conditional
at-rules (`@media`, `@supports`: the drawing read is the one a plain renderer shows),
nor `@import`. A declaration's `!important` is dropped. Cascade (CSS 2.1, 6.4.3): a
rule of higher specificity wins, then the later rule; sheets override presentation
attributes and are overridden by the element's `style` attribute.
"""

import re


_COMMENT = re.compile(r"/\*.*?\*/", re.S)
_COMPOUND = re.compile(r"(\*|[A-Za-z_][\w-]*)?((?:[.#][A-Za-z_][\w-]*)*)$")


def _blocks(text: str):
    """`(prelude, body)` of each top-level rule, at-rules and all, in order."""
    i, n = 0, len(text)
    while i < n:
        brace = text.find("{", i)
        semicolon = text.find(";", i)
        if brace < 0:
            return
        if 0 <= semicolon < brace and text[i:semicolon].strip().startswith("@"):
            i = semicolon + 1  # `@import ...;`, `@charset ...;`
            continue
        depth, j = 1, brace + 1
        while j < n and depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        yield text[i:brace].strip(), text[brace + 1 : j - 1]
        i = j


def _selector(text: str):
    """A selector as a list of (combinator, tag, classes, ids) from left to right, and its
    specificity (ids, classes, types); None for a selector not supported here."""
    parts = re.split(r"\s*(>)\s*|\s+", text.strip())
    steps, combinator, specificity = [], " ", [0, 0, 0]
    for part in parts:
        if part is None or part == "":
            continue
        if part == ">":
            combinator = ">"
            continue
        match = _COMPOUND.match(part)
        if match is None or not part:
            return None
        tag, rest = match.group(1), match.group(2)
        classes = set(re.findall(r"\.([\w-]+)", rest))
        ids = set(re.findall(r"#([\w-]+)", rest))
        specificity[0] += len(ids)
        specificity[1] += len(classes)
        specificity[2] += 1 if tag and tag != "*" else 0
        steps.append((combinator, None if tag in (None, "*") else tag.lower(), classes, ids))
        combinator = " "
    return (steps, tuple(specificity)) if steps else None


def _declarations(body: str) -> dict:
    found = {}
    for declaration in body.split(";"):
        name, colon, value = declaration.partition(":")
        if colon:
            found[name.strip().lower()] = value.lower().replace("!important", "").strip()
    return found


def parse_sheets(texts: list[str]) -> list:
    """The supported rules of the style sheets `texts`, in cascade order (lowest first):
    a list of (steps, declarations)."""
    rules, order = [], 0
    for text in texts:
        for prelude, body in _blocks(_COMMENT.sub("", text)):
            if prelude.startswith("@"):
                continue
            declarations = _declarations(body)
            for selector in prelude.split(","):
                parsed = _selector(selector)
                if parsed is not None and declarations:
                    rules.append((parsed[1], order, parsed[0], declarations))
                    order += 1
    rules.sort(key=lambda rule: (rule[0], rule[1]))
    return [(steps, declarations) for _, _, steps, declarations in rules]


def _matches_one(step, element) -> bool:
    _, tag, classes, ids = step
    if tag is not None and _local(element.tag) != tag:
        return False
    if classes and not classes <= set((element.get("class") or "").split()):
        return False
    return not ids or ids == {element.get("id")}


def _local(tag) -> str:
    return tag.rsplit("}", 1)[-1].lower() if isinstance(tag, str) else ""


def matches(steps, element, ancestors) -> bool:
    """Whether the selector `steps` matches `element`, whose ancestors are the linked
    list `ancestors` ((parent, its ancestors) or None)."""
    if not _matches_one(steps[-1], element):
        return False
    link = ancestors
    for k in range(len(steps) - 2, -1, -1):
        combinator = steps[k + 1][0]
        if combinator == ">":
            if link is None or not _matches_one(steps[k], link[0]):
                return False
            link = link[1]
            continue
        while link is not None and not _matches_one(steps[k], link[0]):
            link = link[1]
        if link is None:
            return False
        link = link[1]
    return True
