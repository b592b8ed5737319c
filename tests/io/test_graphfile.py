"""YAML graph files: each malformed case gives one line naming file, line, key path and fix."""
import textwrap

import pytest

from proxyshade.errors import CycleError, GraphFileError
from proxyshade.graph.graph import Graph
from proxyshade.io.graphfile import parse_frame_list

GOOD = """\
format: proxyshade/1
frames: 1-3
vars: {v: 2.0}
nodes:
  a:   {type: TConst, params: {value: "${v}"}}
  b:   {type: TConst, params: {value: 1.0}}
  s:   {type: TAdd, inputs: {a: a, b: b, prev: {node: s, frame: -1}}}
  w:   {type: ExrWrite, inputs: {image: s}, params: {path: "out/s.####.exr"}}
"""


def write(tmp_path, text):
    p = tmp_path / "g.yaml"
    p.write_text(textwrap.dedent(text))
    return p


def test_good_graph_loads_and_runs(tmp_path, registry):
    g = Graph.load(write(tmp_path, GOOD.replace('"${v}"', "2.0")))
    assert g.frames == (1, 3)
    g.run()
    assert (tmp_path / "out" / "s.0003.exr").is_file()
    assert g.cache.root == tmp_path / ".proxyshade" / "cache"


@pytest.mark.parametrize("old,new,expect", [
    ("format: proxyshade/1", "format: proxyshade/9", r"g.yaml:1: format: expected 'proxyshade/1'"),
    ("value: 1.0}", "value: one}", r"g.yaml:6: nodes.b.params.value: expected float, got 'one'"),
    ("type: TAdd", "type: TAddd", r"g.yaml:7: nodes.s.type: unknown node type 'TAddd'; known types: .*TAdd"),
    ("params: {value: 1.0}", "params: {valu: 1.0}", r"g.yaml:6: nodes.b.params.valu: TConst has no parameter 'valu'; its parameters are value"),
    ("inputs: {a: a, b: b,", "inputs: {a: a, c: b,", r"g.yaml:7: nodes.s.inputs.c: TAdd has no input 'c'; its inputs are a, b, prev"),
    ("inputs: {a: a, b: b,", "inputs: {a: zz, b: b,", r"g.yaml:7: nodes.s.inputs.a: no node 'zz'; nodes are a, b, s, w"),
    ("frame: -1", "frame: last", r"g.yaml:7: nodes.s.inputs.prev.frame: expected an integer offset"),
    ("frames: 1-3", "frames: 3-1", r"g.yaml:2: frames: frame range '3-1' ends before it starts"),
    ("${v}", "${nope}", r"g.yaml:5: nodes.a.params.value: unknown variable \$\{nope\}; defined: v"),
    ("  w:", "  bad: 3\n  w:", r"g.yaml:8: nodes.bad: expected \{type: NodeType"),
    ("nodes:", "nodez:", r"g.yaml:4: nodez: unknown top-level key"),
    ("{type: TConst, params: {value: 1.0}}", "{type: TConst, params: {size: 0}}", r"g.yaml:6: nodes.b.params.size: expected int >= 1, got 0"),
    ("inputs: {image: s}, ", "", r"g.yaml:\d+: nodes.w.inputs.image: not connected"),
    ("frames: 1-3", "frames: [1, 3", r"g.yaml:\d+: not valid YAML"),
    ("frame: -1", "frame: every", r"g.yaml:7: nodes.s.inputs.prev.frame: expected an integer offset \(e.g. -1\), 'first' or 'all'"),
    ("prev: {node: s, frame: -1}", "prev: {node: a, frame: all}",
     r"g.yaml:7: nodes.s.inputs.prev: _?TAdd input 'prev' takes one plate, not the whole sequence; drop 'frame: all'"),
    ("  w:", "  q:   {type: TSeq, inputs: {image: s}}\n  w:",
     r"g.yaml:8: nodes.q.inputs.image: _?TSeq reads the whole sequence here; connect it as \{node: s, frame: all\}"),
    ("  w:", "  q:   {type: TSeq, inputs: {image: {node: s, frame: all}}}\n  r:   {type: TAdd, inputs: {a: q}}\n  w:",
     r"g.yaml:9: nodes.r.inputs.a: q \(_?TSeq\) reads the whole sequence and runs once per run, so no node can read it"),
])
def test_malformed_yaml_gives_one_line_error(tmp_path, registry, old, new, expect):
    text = GOOD.replace(old, new)
    assert text != GOOD
    with pytest.raises(GraphFileError, match=expect) as e:
        Graph.load(write(tmp_path, text))
    assert "\n" not in str(e.value)


def test_missing_file_and_cycle(tmp_path, registry):
    with pytest.raises(GraphFileError, match="nothere.yaml: cannot read graph file"):
        Graph.load(tmp_path / "nothere.yaml")
    cyc = GOOD.replace("prev: {node: s, frame: -1}", "prev: s")
    with pytest.raises(CycleError, match=r"g.yaml: cycle s@(\d) -> s@\1; break it"):
        Graph.load(write(tmp_path, cyc)).run()


def test_overrides_and_relative_paths(tmp_path, registry):
    g = Graph.load(write(tmp_path, GOOD.replace('"${v}"', "2.0")), overrides=["b.value=4", "s.enabled=false"])
    assert g.nodes["b"].params["value"] == 4.0 and g.enabled["s"] is False
    with pytest.raises(GraphFileError, match=r"--set b.value=x: b.value: expected float, got 'x'"):
        Graph.load(write(tmp_path, GOOD.replace('"${v}"', "2.0")), overrides=["b.value=x"])


def test_frame_all_connects_a_sequence_input(tmp_path, registry):
    text = GOOD.replace('"${v}"', "2.0") + "  q:   {type: TSeq, inputs: {image: {node: s, frame: all}}}\n"
    g = Graph.load(write(tmp_path, text))
    assert g.connections["q"]["image"].all
    g.run([2])
    assert g.value("q", 2).meta["frames"] == [1, 2]


def test_frame_lists():
    assert parse_frame_list("1-3,7,9-10") == [1, 2, 3, 7, 9, 10]
    with pytest.raises(GraphFileError):
        parse_frame_list("a-b")
