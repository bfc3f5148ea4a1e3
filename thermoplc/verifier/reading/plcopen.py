"""PLCopen TC6 XML 2.01 -> the AST of a block (verifier/reading/syntax.py): the same AST its .st source gives.

`thermoplc generate --dialect iec --format plcopen` writes the iec block as PLCopen XML, the form
CODESYS and TwinCAT import. This reader takes the one function block of such a file: its interface
(sections, types, start values, constants, RETAIN) from the XML elements, its body from the ST text,
parsed by the verifier's own grammar (`parser.parse_body`, `parser.parse_literal`). So replay, the
constants check and diff work on the XML as on the .st, and a changed constant or statement in the
XML fails `verify` as it would in the .st. Positions in messages and in the AST are the XML file's
lines and columns (exact for a body in CDATA, as generate writes it and CODESYS exports it), so
`diff` quotes the XML's own lines.

The standard library's expat parser reads the XML; a DOCTYPE (where entities would be declared) is
refused before anything is expanded. What could change what the block computes and is not read
here -- a second POU, actions or transitions, a body in another language, vendor data in the POU
(CODESYS and TwinCAT methods and properties), a type other than REAL, BOOL, INT, DINT and arrays
of them, an address -- is refused with the file, line and column, never skipped. The reader does
not import the generator: the proof does not ask the code it proves.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from xml.etree import ElementTree as ET
from xml.parsers import expat

from thermoplc.base.errors import UserError
from thermoplc.verifier.reading import syntax as s
from thermoplc.verifier.reading.parser import SUPPORTED_TYPES, array_type, parse_body, parse_literal
from thermoplc.verifier.reading.bench_source import bench_transformer

TC6 = "http://www.plcopen.org/xml/tc6_0201"
XHTML = "http://www.w3.org/1999/xhtml"
EXPECTED = "expected PLCopen TC6 XML 2.01 holding one function block, as generate --format plcopen writes"
SECTIONS = {"inputVars": "input", "outputVars": "output", "localVars": "static", "tempVars": "temp"}
UNSUPPORTED_SECTIONS = {"inOutVars": "VAR_IN_OUT", "externalVars": "VAR_EXTERNAL", "globalVars": "VAR_GLOBAL",
                        "accessVars": "VAR_ACCESS"}
RETAINABLE = ("output", "static")  # VAR_OUTPUT RETAIN and VAR RETAIN, as an ST block declares them
LANGUAGES = ("IL", "ST", "FBD", "LD", "SFC")
IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")  # the grammar's NAME
BOOLEAN = {"true": True, "1": True, "false": False, "0": False}  # xsd:boolean
INTEGER = re.compile(r"[+-]?[0-9]+\Z")
DECLARED_ENCODING = re.compile(r"""<\?xml[^>]*?\sencoding\s*=\s*(["'])([^"']*)\1""")
PROJECT_CHILDREN = ("fileHeader", "contentHeader", "types", "instances", "addData", "documentation")
CONTAINER_CHILDREN = {"types": ("dataTypes", "pous"), "instances": ("configurations",)}
VARIABLE_CHILDREN = ("type", "initialValue", "documentation", "addData")


def is_xml(text: str) -> bool:
    """An XML document, told by its content: ST starts with a keyword or a comment, never with '<'."""
    return text.lstrip().startswith("<")


def _q(local: str) -> str:
    return f"{{{TC6}}}{local}"


def _local(element: ET.Element) -> str:
    return element.tag.rpartition("}")[2]


@dataclass(frozen=True)
class _Content:
    """Character data (or a comment, a processing instruction) with the open elements it lies in."""
    inside: tuple[ET.Element, ...]
    after_child: bool
    start: tuple[int, int]
    what: str


def _first_visible(chunk: str, line: int, column: int) -> tuple[int, int]:
    """Where the first non-blank character of a chunk of character data is, from where the chunk starts."""
    lead = chunk[:len(chunk) - len(chunk.lstrip())]
    breaks = lead.count("\n")
    return (line + breaks, len(lead) - lead.rfind("\n")) if breaks else (line, column + len(lead))


def _is_tc6(element: ET.Element, local: str) -> bool:
    return element.tag == _q(local)


class _Document:
    """The element tree with where each element starts (and where its text starts) in the file."""

    def __init__(self, text: str, source: str):
        self.source = source
        self.bench = False  # a test bench (read_plcopen)
        self.starts: dict[ET.Element, tuple[int, int]] = {}
        self.text_starts: dict[ET.Element, tuple[int, int]] = {}
        self.content: list[_Content] = []
        parser = expat.ParserCreate(namespace_separator="}")
        builder = ET.TreeBuilder()
        open_elements: list[ET.Element] = []
        has_child: set[ET.Element] = set()

        def here() -> tuple[int, int]:
            return parser.CurrentLineNumber, parser.CurrentColumnNumber + 1

        def start(tag, attributes):
            element = builder.start("{" + tag if "}" in tag else tag, attributes)
            self.starts[element] = here()
            if open_elements:
                has_child.add(open_elements[-1])
            open_elements.append(element)

        def end(tag):
            builder.end("{" + tag if "}" in tag else tag)
            open_elements.pop()

        def data(chunk):
            if open_elements and open_elements[-1] not in self.text_starts:
                self.text_starts[open_elements[-1]] = here()
            if chunk.strip() and open_elements:
                text = chunk.strip()
                self.content.append(_Content(tuple(open_elements), open_elements[-1] in has_child,
                                             _first_visible(chunk, *here()),
                                             repr(text if len(text) <= 40 else text[:37] + "...")))
            builder.data(chunk)

        def markup(kind):
            def seen(*_):
                self.content.append(_Content(tuple(open_elements), True, here(), kind))
            return seen

        def doctype(*_):
            line, column = here()
            begins = text.find("<!DOCTYPE")
            if 0 <= begins and text.count("\n", 0, begins) < line:  # where it begins, not where expat is inside it
                line, column = s.position(text, begins)
            raise UserError(f"{source}:{line}:{column}: a DOCTYPE is refused (entity declarations could expand "
                            f"without bound, and PLCopen XML needs none); {EXPECTED}")

        parser.StartElementHandler, parser.EndElementHandler, parser.CharacterDataHandler = start, end, data
        parser.StartDoctypeDeclHandler = doctype
        parser.CommentHandler, parser.ProcessingInstructionHandler = markup("a comment"), markup("a processing instruction")
        try:
            parser.Parse(text, True)
        except expat.ExpatError as exc:
            raise UserError(f"{source}:{exc.lineno}:{exc.offset + 1}: not well-formed XML "
                            f"({expat.ErrorString(exc.code)}); {EXPECTED}") from None
        self.root = builder.close()

    def refuse_unread_content(self, body_text: ET.Element) -> None:
        """Text an importer could read as code and this reader would skip is refused where it starts: anything
        but whitespace outside the body's one XHTML element (text after </xhtml:p>, between sections, after
        <ST>), and markup splitting the body. Documentation is free text, as the importers read it; vendor data
        (addData) is judged by its elements, elsewhere."""
        for content in self.content:
            if any(_is_tc6(element, "documentation") or _is_tc6(element, "addData") for element in content.inside):
                continue
            if content.inside and content.inside[-1] is body_text and not content.after_child:
                continue
            line, column = content.start
            inside = content.inside[-1] if content.inside else None
            where = "outside <project>" if inside is None else \
                f"in <xhtml:{_local(inside)}>" if inside.tag.startswith(f"{{{XHTML}}}") else f"in <{_local(inside)}>"
            raise UserError(f"{self.source}:{line}:{column}: {content.what} {where} is not read by the verifier, "
                            f"so it cannot prove the block with it; expected the body's ST text in one XHTML "
                            f"element (<xhtml:p><![CDATA[...]]></xhtml:p>) and only whitespace between elements")

    def at(self, element: ET.Element) -> str:
        line, column = self.starts[element]
        return f"{self.source}:{line}:{column}"

    def fail(self, element: ET.Element, message: str):
        raise UserError(f"{self.at(element)}: {message}")


def _refuse_other_encoding(text: str, source: str, encoding: str) -> None:
    """The file is decoded as UTF-8, or as its byte order mark says: an XML declaration naming another
    encoding makes importers disagree (some follow the declaration, some the mark, expat refuses), so
    it is refused unless it names the encoding the file was read in."""
    declared = DECLARED_ENCODING.match(text.lstrip("\ufeff"))
    if declared is None:
        return
    name = declared.group(2).lower().replace("_", "-").replace("utf8", "utf-8")
    family = {"utf-8-sig": "utf-8"}.get(encoding, encoding)
    if name == family or (family in ("utf-16", "utf-32") and name in (family, f"{family}le", f"{family}be",
                                                                      f"{family}-le", f"{family}-be")):
        return
    line, column = s.position(text, len(text) - len(text.lstrip("\ufeff")) + declared.start(2))
    mark = "has no byte order mark and is read as UTF-8" if encoding == "utf-8" else \
        f"is read as {family.upper()}, as its byte order mark says"
    raise UserError(f"{source}:{line}:{column}: the XML declaration says encoding={declared.group(2)!r}, but the file "
                    f"{mark}; importers would read other characters; expected encoding=\"{family}\"")


def read_plcopen(text: str, source: str, encoding: str = "utf-8", bench: bool = False) -> s.Program:
    """The one function block of a PLCopen XML file as the verifier's AST, or a UserError naming
    the file, the line and column, and what was expected. `encoding` is what the file was decoded
    as; the XML declaration must not name another. `bench`: a test bench, which may hold an
    instance of the block under test (a derived type), call it and read its outputs."""
    if not is_xml(text):
        found = (text.lstrip().splitlines() or [""])[0][:20]
        raise UserError(f"{source}:1:1: not XML (it starts with {found!r}, not '<?xml' or '<project'); {EXPECTED}")
    _refuse_other_encoding(text, source, encoding)
    doc = _Document(text, source)
    doc.bench = bench
    root = doc.root
    if root.tag != _q("project"):
        namespace = root.tag[1:].partition("}")[0] if root.tag.startswith("{") else "no namespace"
        doc.fail(root, f"the root element is <{_local(root)}> in {namespace}; {EXPECTED} (<project> in {TC6})")
    _only_known_children(doc, root, PROJECT_CHILDREN, "the project")
    for child in root:
        if child.tag in (_q("types"), _q("instances")):
            _only_known_children(doc, child, CONTAINER_CHILDREN[_local(child)], f"<{_local(child)}>")
            for empty in (c for c in child if c.tag in (_q("dataTypes"), _q("configurations"))):
                _empty(doc, empty, f"<{_local(empty)}> holds what the verifier does not read (types or "
                                   f"configurations beside the block)")
            for pous in (c for c in child if c.tag == _q("pous")):
                _only_known_children(doc, pous, ("pou",), "<pous>")
    pous = root.findall(f"{_q('types')}/{_q('pous')}/{_q('pou')}")
    if not pous:
        doc.fail(root, f"no <pou> in <types><pous>; {EXPECTED}")
    if len(pous) > 1:
        doc.fail(pous[1], f"a second POU {pous[1].get('name')!r} after {pous[0].get('name')!r}; expected one "
                          f"function block per file (generate writes one)")
    return _pou(doc, pous[0])


def _only_known_children(doc: _Document, element: ET.Element, known: tuple[str, ...], what: str) -> None:
    """Every child a TC6 element this reader knows, each at most once (an importer may take the other copy)."""
    seen: set[str] = set()
    for child in element:
        local = _local(child)
        if not child.tag.startswith(f"{{{TC6}}}") or local not in known:
            doc.fail(child, f"<{local}> in {what} is not read by the verifier, so it cannot prove the block with it; "
                            f"expected {', '.join(f'<{k}>' for k in known)}")
        if local in seen and local not in ("pou", "documentation"):
            doc.fail(child, f"a second <{local}> in {what}; expected one (an importer may read the other)")
        seen.add(local)


def _empty(doc: _Document, element: ET.Element, message: str) -> None:
    if len(element):
        doc.fail(element[0], message)


def _pou(doc: _Document, pou: ET.Element) -> s.Program:
    name = _identifier(doc, pou, "POU")
    if pou.get("pouType") != "functionBlock":
        doc.fail(pou, f"POU {name!r} is a {pou.get('pouType') or '(no pouType)'}; expected a functionBlock")
    interface, bodies = None, []
    for child in pou:
        local = _local(child) if child.tag.startswith(f"{{{TC6}}}") else child.tag
        if local == "interface" and interface is None:
            interface = child
        elif local == "body":
            bodies.append(child)
        elif local in ("actions", "transitions") and not len(child):
            continue
        elif local == "addData" and not len(child):
            continue
        elif local == "addData":
            data = child[0]
            doc.fail(data, f"vendor data {data.get('name') or _local(data)!r} in POU {name!r} (a method, property "
                           f"or setting) is not read by the verifier, so it cannot prove the block with it; "
                           f"{EXPECTED}")
        elif local != "documentation":
            doc.fail(child, f"<{local}> in POU {name!r} is not read by the verifier (actions, transitions and "
                            f"vendor elements are not supported); {EXPECTED}")
    decls, retained = _interface(doc, interface, name) if interface is not None else ((), [])
    if not bodies:
        doc.fail(pou, f"POU {name!r} has no <body>; expected its ST body")
    if len(bodies) > 1:
        doc.fail(bodies[1], f"a second <body> in POU {name!r}; expected one ST body")
    header = (("RETAIN", ", ".join(sorted(set(retained)))),) if retained else ()
    return s.Program(name, decls, _body(doc, bodies[0], name), header, ())


def _identifier(doc: _Document, element: ET.Element, what: str) -> str:
    name = element.get("name")
    if name is None or not IDENTIFIER.match(name):
        doc.fail(element, f"{what} name {name!r}: expected an ST identifier (letters, digits, '_')")
    return name


def _flag(doc: _Document, element: ET.Element, attribute: str) -> bool:
    value = element.get(attribute, "false").strip()
    if value not in BOOLEAN:
        doc.fail(element, f"{attribute}={value!r}: expected true or false")
    return BOOLEAN[value]


def _interface(doc: _Document, interface: ET.Element, pou: str) -> tuple[tuple[s.VarDecl, ...], list[str]]:
    decls: list[s.VarDecl] = []
    retained: list[str] = []
    for group in interface:
        local = _local(group) if group.tag.startswith(f"{{{TC6}}}") else group.tag
        if local == "addData":
            _empty(doc, group, f"vendor data in the interface of POU {pou!r} is not read by the verifier, so it "
                               f"cannot prove the block with it")
            continue
        if local == "documentation":
            continue
        if local in UNSUPPORTED_SECTIONS:
            doc.fail(group, f"<{local}> ({UNSUPPORTED_SECTIONS[local]} section) is not supported")
        if local == "returnType":
            doc.fail(group, f"<returnType> in POU {pou!r}: a function's; expected a functionBlock")
        if local not in SECTIONS:
            doc.fail(group, f"<{local}> in the interface of POU {pou!r}: expected inputVars, outputVars, localVars "
                            f"or tempVars")
        section = SECTIONS[local]
        if _flag(doc, group, "persistent"):
            doc.fail(group, f"<{local} persistent=\"true\">: PERSISTENT variables are not supported")
        constant, retain = _flag(doc, group, "constant"), _flag(doc, group, "retain")
        if retain and _flag(doc, group, "nonretain"):
            doc.fail(group, f"<{local}> is both retain and nonretain")
        if constant and section != "static":
            doc.fail(group, f"<{local} constant=\"true\">: IEC declares constants in VAR CONSTANT; expected "
                            f"<localVars constant=\"true\">")
        if constant:
            section = "constant"
        if retain and section not in RETAINABLE:
            doc.fail(group, f"<{local} retain=\"true\">: only outputVars and localVars (not constants) are declared "
                            f"RETAIN (VAR_OUTPUT RETAIN, VAR RETAIN)")
        if retain:
            retained.append(section)
        for variable in group:
            kind = _local(variable) if variable.tag.startswith(f"{{{TC6}}}") else variable.tag
            if kind == "addData":
                _empty(doc, variable, f"vendor data in <{local}> is not read by the verifier, so it cannot prove "
                                      f"the block with it")
                continue
            if kind == "documentation":
                continue
            if kind != "variable":
                doc.fail(variable, f"<{kind}> in <{local}>: expected <variable> elements")
            decls.append(_variable(doc, variable, section))
    return tuple(decls), retained


def _variable(doc: _Document, variable: ET.Element, section: str) -> s.VarDecl:
    name = _identifier(doc, variable, "variable")
    _only_known_children(doc, variable, VARIABLE_CHILDREN, f"variable {name!r}")
    for data in variable.findall(_q("addData")):
        _empty(doc, data, f"vendor data on variable {name!r} is not read by the verifier, so it cannot prove the "
                          f"block with it")
    if variable.get("address") is not None:
        doc.fail(variable, f"variable {name!r} at address {variable.get('address')!r}: AT address is not supported")
    type_element = variable.find(_q("type"))
    if type_element is None:
        doc.fail(variable, f"variable {name!r} has no <type>")
    type_ref = _type(doc, type_element, name)
    start = variable.find(_q("initialValue"))
    initial = None if start is None else _initial(doc, start, name)
    line, column = doc.starts[variable]
    return s.VarDecl(name, section, type_ref, initial, (line, column))


def _unsupported_type(doc: _Document, element: ET.Element, variable: str):
    local = _local(element)
    shown = f"{element.get('name')!r} (a derived type)" if local == "derived" else local
    doc.fail(element, f"variable {variable!r}: type {shown} is not supported (REAL, BOOL, INT, DINT and arrays of "
                      f"them are)")


def _only_child(doc: _Document, element: ET.Element, what: str) -> ET.Element:
    children = list(element)
    if len(children) != 1:
        doc.fail(element, f"{what}: {len(children)} elements in <{_local(element)}>; expected one")
    return children[0]


def _scalar(doc: _Document, element: ET.Element, variable: str) -> str:
    if element.tag.startswith(f"{{{TC6}}}") and _local(element) in SUPPORTED_TYPES:
        return _local(element)
    _unsupported_type(doc, element, variable)


def _type(doc: _Document, type_element: ET.Element, variable: str) -> s.TypeRef:
    element = _only_child(doc, type_element, f"the type of variable {variable!r}")
    if doc.bench and element.tag == _q("derived") and IDENTIFIER.match(element.get("name") or ""):
        return s.TypeRef("BLOCK", block=element.get("name"))
    if element.tag != _q("array"):
        return s.TypeRef(_scalar(doc, element, variable))
    dimensions = element.findall(_q("dimension"))
    if len(dimensions) != 1:
        doc.fail(element, f"variable {variable!r}: an array of {len(dimensions)} dimensions; expected one")
    bounds = [dimensions[0].get(key, "").strip() for key in ("lower", "upper")]
    if not all(INTEGER.match(b) for b in bounds):
        doc.fail(dimensions[0], f"variable {variable!r}: array bounds {bounds[0]!r}..{bounds[1]!r}; expected integers")
    base = element.find(_q("baseType"))
    if base is None:
        doc.fail(element, f"variable {variable!r}: an array without <baseType>")
    scalar = _scalar(doc, _only_child(doc, base, f"the base type of variable {variable!r}"), variable)
    return array_type(int(bounds[0]), int(bounds[1]), scalar, doc.at(element))


def _initial(doc: _Document, start: ET.Element, variable: str):
    value = _only_child(doc, start, f"the start value of variable {variable!r}")
    if value.tag == _q("simpleValue"):
        return _simple(doc, value, variable)
    if value.tag != _q("arrayValue"):
        doc.fail(value, f"variable {variable!r}: a start value <{_local(value)}>; expected <simpleValue> or "
                        f"<arrayValue>")
    items = []
    for item in value:
        if item.tag != _q("value"):
            doc.fail(item, f"variable {variable!r}: <{_local(item)}> in <arrayValue>; expected <value> elements")
        if item.get("repetitionValue") is not None:
            doc.fail(item, f"variable {variable!r}: repetitionValue is not supported; write each value")
        simple = _only_child(doc, item, f"a value of variable {variable!r}")
        if simple.tag != _q("simpleValue"):
            doc.fail(simple, f"variable {variable!r}: <{_local(simple)}> in an array; expected <simpleValue>")
        items.append(_simple(doc, simple, variable))
    if not items:
        doc.fail(value, f"variable {variable!r}: an empty <arrayValue>")
    return tuple(items)


def _simple(doc: _Document, element: ET.Element, variable: str):
    text = element.get("value")
    if text is None:
        doc.fail(element, f"variable {variable!r}: <simpleValue> without a value")
    return parse_literal(text, doc.source, f"{doc.at(element)}: variable {variable!r}")


def _body(doc: _Document, body: ET.Element, pou: str) -> tuple[s.Stmt, ...]:
    languages = [child for child in body if child.tag.startswith(f"{{{TC6}}}") and _local(child) in LANGUAGES]
    others = [child for child in body if child not in languages and child.tag not in (_q("addData"), _q("documentation"))]
    for data in body.findall(_q("addData")):
        _empty(doc, data, f"vendor data in the body of POU {pou!r} (a method or an action?) is not read by the "
                          f"verifier, so it cannot prove the block with it")
    if others:
        doc.fail(others[0], f"<{_local(others[0])}> in the body of POU {pou!r}; expected <ST>")
    if not languages:
        doc.fail(body, f"the body of POU {pou!r} holds no <ST>; expected its ST text")
    st = languages[0]
    if _local(st) != "ST":
        doc.fail(st, f"the body of POU {pou!r} is in {_local(st)}; the verifier reads ST bodies only")
    if len(languages) > 1:
        doc.fail(languages[1], f"a second body language <{_local(languages[1])}> after <ST> in POU {pou!r}; "
                               f"expected one ST body (an importer may read the other)")
    texts = list(st)
    if len(texts) != 1 or not texts[0].tag.startswith(f"{{{XHTML}}}") or len(texts[0]) or (st.text or "").strip():
        doc.fail(st, f"the ST body of POU {pou!r}: expected its text in one XHTML element "
                     f"(<xhtml:p><![CDATA[...]]></xhtml:p>)")
    text = texts[0]
    if text.tag != f"{{{XHTML}}}p":
        doc.fail(text, f"the ST body of POU {pou!r} is in <xhtml:{_local(text)}>; expected <xhtml:p>")
    for element in (st, text):
        if element.attrib:
            doc.fail(element, f"attribute {next(iter(element.attrib))!r} on <{_local(element)}> is not read by the "
                              f"verifier; expected none")
    doc.refuse_unread_content(text)
    line, column = doc.text_starts.get(text, doc.starts[text])
    return parse_body(text.text or "", doc.source, line, column, bench_transformer(doc.source) if doc.bench else None)
