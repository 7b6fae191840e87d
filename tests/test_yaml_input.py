"""The YAML reader's two parsers: libyaml's (fast) must give exactly the data PyYAML's own gives, and
refuse at least what it refuses (a refusal is then worded by PyYAML's, ``yaml_input._parse_yaml``)."""

import math
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from planner import yaml_input
from planner.errors import PlannerError

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(not yaml.__with_libyaml__, reason="PyYAML without libyaml: one parser only")


def loaded(loader_class, text: str):
    """("data", the document) or ("refused", None) by one loader class."""
    loader = None
    try:
        loader = loader_class(text)  # PyYAML's checks every character here
        return "data", loader.get_single_data()
    except (yaml.YAMLError, PlannerError):
        return "refused", None
    finally:
        if loader is not None:
            loader.dispose()


def same(a, b) -> bool:
    """Equal data, NaN equal to NaN, and of the same types (1 is not 1.0, True is not 1)."""
    if type(a) is not type(b):
        return False
    if isinstance(a, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    if isinstance(a, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return list(a) == list(b) and all(same(a[k], b[k]) for k in a)
    return a == b


def parsed(text: str):
    """("data", the document) or ("refused", None) as the reader gives them."""
    try:
        return "data", yaml_input._parse_yaml(text, Path("test.yaml"))
    except PlannerError:
        return "refused", None


def assert_agree(text: str) -> None:
    """The reader's data or refusal is PyYAML's own, whichever parser read the text."""
    reader, pure = parsed(text), loaded(yaml_input._StrictLoader, text)
    assert reader[0] == pure[0] and same(reader[1], pure[1]), text


@pytest.mark.parametrize("path", sorted((ROOT / "scripts" / "tasks").glob("*.yaml")), ids=lambda path: path.name)
def test_the_bundled_tasks_are_read_by_libyaml_to_pyyamls_data(path):
    text = path.read_text()
    assert yaml_input._LIBYAML_TEXT.fullmatch(text) and loaded(yaml_input._FastStrictLoader, text)[0] == "data"
    assert_agree(text)


def test_the_edge_cases_file_reads_as_pyyaml_reads_it():
    assert_agree((ROOT / "tests" / "edge_cases.yaml").read_text())


FRAGMENTS = ["a", "b", "1", "-2.5e-3", "1e999", "0x1F", "0o17", "010", "1_000", ".inf", ".nan", "~", "null", "true",
             "yes", "1:40", "2001-12-14", "'x'", '"y\\n"', "! 60", "!!str 5", "&x", "*x", "<<", ":", ": ", "- ",
             "-", "[", "]", "{", "}", ", ", "\n", "\n  ", "\t", " ", "#c", "|", ">", "?", "%", "@", "`", "\x01",
             "\ufeff", "é", "---", "..."]


@settings(max_examples=400, derandomize=True, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.sampled_from(FRAGMENTS), max_size=30))
def test_random_documents_read_the_same_or_are_refused_by_both(parts):
    assert_agree("".join(parts))


PLAIN_FRAGMENTS = [fragment for fragment in FRAGMENTS if yaml_input._LIBYAML_TEXT.fullmatch(fragment)] + [
    "\n- ", "\n  - ", "k: ", "\nk2: ", "'a''b'", '"\\t"', "\\", "#", "\n#x\n", "=", "+", "/", ";", "(", ")", "$"]


@settings(max_examples=400, derandomize=True, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.sampled_from(PLAIN_FRAGMENTS), max_size=30))
def test_documents_libyaml_reads_give_pyyamls_data_or_refusal(parts):
    """The texts the fast parser takes: both parsers' data equal, or both refuse."""
    text = "".join(parts)
    assert yaml_input._LIBYAML_TEXT.fullmatch(text)
    fast, pure = loaded(yaml_input._FastStrictLoader, text), loaded(yaml_input._StrictLoader, text)
    assert fast[0] == pure[0] and same(fast[1], pure[1]), text


@settings(max_examples=200, derandomize=True, deadline=None, database=None)
@given(st.recursive(st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=12)),
                    lambda inner: st.one_of(st.lists(inner, max_size=5),
                                            st.dictionaries(st.text(max_size=6), inner, max_size=4)),
                    max_leaves=25),
       st.sampled_from([None, True, False]))
def test_dumped_data_reads_the_same_by_both_parsers(data, flow):
    assert_agree(yaml.safe_dump(data, default_flow_style=flow, allow_unicode=True))


def test_a_refusal_is_worded_by_pythons_parser(tmp_path):
    """libyaml places errors in bytes and words them its own way: the message is PyYAML's."""
    path = tmp_path / "bad.yaml"
    path.write_text("é: [1, 2\nb: 3\n")
    with pytest.raises(PlannerError) as fast:
        yaml_input.read_yaml(path)
    with pytest.raises(yaml.YAMLError) as pure:
        yaml_input._StrictLoader(path.read_text()).get_single_data()
    assert str(pure.value.problem) in str(fast.value) and f"line {pure.value.problem_mark.line + 1}" in str(fast.value)
