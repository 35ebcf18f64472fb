"""An evidence page's words come from templates a writer edits, its figures from JSON."""

from pathlib import Path
import sys

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / 'tools'))

import close_loop_doc  # noqa: E402
import evidence_summary  # noqa: E402


def test_the_close_the_loop_page_is_its_templates_filled_in():
    records, synth, long_run = close_loop_doc.load(ROOT / 'docs')
    page = evidence_summary.with_summary(
        close_loop_doc.render(records, synth, long_run),
        evidence_summary.render_close_loop(ROOT / 'docs' / 'close-the-loop'))
    assert page == (ROOT / 'docs' / 'close-the-loop.md').read_text(), \
        'docs/close-the-loop.md differs from its templates: run make close-the-loop-page'


def test_every_trace_with_words_is_on_the_page_and_no_placeholder_is_left(tmp_path):
    words = close_loop_doc.trace_words()
    records, synth, long_run = close_loop_doc.load(ROOT / 'docs')
    assert {r['trace'] for r in records} <= set(words)
    template = tmp_path / 'page.md'
    template.write_text('{{SYNTHETIC}}\n{{NO_SUCH_TABLE}}\n')
    try:
        close_loop_doc.render(records, synth, long_run, template)
    except ValueError as exc:
        assert 'NO_SUCH_TABLE' in str(exc)
    else:
        raise AssertionError('a placeholder without a table was left in the page')


def test_the_generalisation_page_is_its_template_filled_in(tmp_path):
    import shutil
    import subprocess
    src = ROOT / 'docs' / 'generalisation'
    shutil.copytree(src, tmp_path / 'docs' / 'generalisation')
    subprocess.run([sys.executable, str(ROOT / 'tools' / 'generalisation.py'), '--from-json',
                    '--data', str(ROOT / 'data'), '--out', str(tmp_path)],
                   check=True, capture_output=True, cwd=ROOT)
    built = (tmp_path / 'docs' / 'generalisation.md').read_text()
    built = evidence_summary.with_summary(built, evidence_summary.render(src))
    assert built == (ROOT / 'docs' / 'generalisation.md').read_text(), \
        'docs/generalisation.md differs from tools/templates/generalisation.md: run ' \
        'python tools/generalisation.py --from-json --data data --out .'


def test_the_calibration_page_is_its_template_filled_in():
    import calibration_doc
    page = evidence_summary.with_summary(
        calibration_doc.render(calibration_doc.load(ROOT / 'docs')),
        evidence_summary.render_calibration(ROOT / 'docs' / 'calibration'))
    assert page == (ROOT / 'docs' / 'calibration.md').read_text(), \
        'docs/calibration.md differs from tools/templates/calibration.md: run ' \
        'make calibration-page'


def test_a_template_names_a_missing_field():
    import page_template
    template = page_template.Template('walks')
    try:
        template.snippet('family', occasions=5)
    except KeyError as exc:
        assert 'walks.md' in str(exc) and 'smallest' in str(exc)
    else:
        raise AssertionError('a field without a value was filled in silently')
