"""The documentation site builds strictly, and browses from disk as a reader opens it."""

from pathlib import Path
import re

ROOT = Path(__file__).resolve().parents[2]
ROLE = re.compile(r':(?:class|mod|func|meth|attr|data|exc|obj):')
HREF = re.compile(r'href="([^"]*)"')


def test_mkdocs_builds_the_site_strictly(site):
    home = (site / 'index.html').read_text()
    assert 'gps_error_ros' in home
    # the home page shows what the package makes: the demo's figure
    assert 'src="images/demo.png"' in home and (site / 'images' / 'demo.png').stat().st_size
    api = (site / 'reference' / 'api.html').read_text()
    assert 'load_profile' in api and 'to_dict' in api and 'Profile.save' in api


def test_every_link_of_the_site_opens_a_file_from_disk(site):
    """A link to a folder shows a directory listing in a browser reading files: none."""
    # 404.html is a web server's page (absolute links by design); from disk no link leads to it
    pages = sorted(p for p in site.rglob('*.html') if p.name != '404.html')
    assert len(pages) > 30
    for page in pages:
        for href in HREF.findall(page.read_text()):
            if re.match(r'[a-z]+:', href) or href.startswith('#'):
                continue                     # another site, or a place on this page
            target = (page.parent / href.split('#')[0].split('?')[0]).resolve()
            assert target.is_file(), f'{page.relative_to(site)}: {href} is not a file'


def test_no_page_shows_raw_docstring_markup(site):
    for page in sorted(site.rglob('*.html')):
        text = page.read_text()
        assert not ROLE.search(text), (page.relative_to(site), ROLE.search(text).group(0))


def test_decision_records_sit_behind_their_index(site):
    """Every record is built and linked from the index, and no other page's navigation lists it."""
    records = sorted((ROOT / 'docs' / 'decisions').glob('0*.md'))
    index = (site / 'decisions' / 'index.html').read_text()   # README.md becomes index.html
    for record in records:
        assert (site / 'decisions' / f'{record.stem}.html').exists(), record.name
        assert f'{record.stem}.html' in index, record.name
    for page in ('node.html', 'tutorials/python.html', 'presets.html'):
        assert records[0].stem not in (site / page).read_text(), page
