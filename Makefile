# The two commands of the README: `make demo` and `make test`. Both create
# .venv on first use (ROS 2 Jazzy from PyPI wheels + the package, editable)
# and reuse it afterwards. Every ROS process started from here keeps DDS on
# loopback, in a domain of its own for this run.
SHELL := /bin/bash
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
PIP := $(PY) -m pip install --disable-pip-version-check --quiet

export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
ROS_DOMAIN_ID ?= $(shell shuf -i 1-100 -n 1)
export ROS_DOMAIN_ID
export AMENT_PREFIX_PATH := $(abspath $(VENV))
export PYTHONUNBUFFERED := 1

DEMO_OUT ?= demo_output
DEMO_HOURS ?= 2

.PHONY: setup system-packages demo demo-sumo test lint clean calibration-doc bench soak diagnose-long close-the-loop-doc close-the-loop-page \
	generalisation-page calibration-page p2v \
	walks-profile generalisation docs input-sweep site-screenshots gpsd-check presets model-page

# The measured recordings the evidence targets read: the repository's data/
# (see data/README.md); DATA=folder for another set (held-out recordings, UrbanNav).
DATA ?= data

setup: $(STAMP)

$(STAMP): requirements.txt requirements-ros.txt requirements-dev.txt requirements-import.txt \
		requirements-sumo.txt requirements-zones.txt requirements-docs.txt \
		requirements-fast.txt requirements-smoother.txt requirements-parquet.txt \
		requirements-dask.txt requirements-ns3.txt setup.py setup.cfg package.xml
	test -x $(PY) || python3 -m venv $(VENV)
	$(PIP) -r requirements.txt -r requirements-ros.txt -r requirements-dev.txt \
		-r requirements-import.txt -r requirements-sumo.txt -r requirements-zones.txt \
		-r requirements-docs.txt -r requirements-fast.txt -r requirements-smoother.txt \
		-r requirements-parquet.txt -r requirements-dask.txt -r requirements-ns3.txt
	$(PIP) --no-deps -e . --config-settings editable_mode=compat
	touch $@

demo: setup
	$(PY) -m gps_error_ros.ros.demo --out $(DEMO_OUT) --hours $(DEMO_HOURS)

# SUMO live: SUMO's pedestrians through gps_error_sumo and the error node
# (agent_pattern); figure and trace in demo_sumo_output/. About a minute.
demo-sumo: setup
	$(PY) -m gps_error_ros.ros.sumo_demo --out demo_sumo_output

# The pedestrian-to-vehicle study in ns-3 (docs/p2v.md): 100 pedestrians' phones at a
# crossing, 20 vehicles warning from their messages, 60 simulated seconds, with no GPS
# errors, white noise of DS5's size, DS5 and phone-suburban-drive; p2v_output/p2v.json
# and p2v.png. About 25 minutes on two cores (P2V_ARGS for other sizes).
P2V_ARGS ?=
p2v: setup
	$(PY) -m gps_error_ros.ns3.p2v --out p2v_output $(P2V_ARGS)

# Three workers (pytest-xdist), each in a ROS domain of its own (test/conftest.py):
# on two cores a third worker uses the cores better, since the node tests spend
# much of their time waiting on a peer process or the graph. About 15 minutes
# on a quiet two-core machine (docs/performance.md, The test suite).
test: setup system-packages
	$(PY) -m pytest -n 3

# Debian's packages the tests use beside PyPI's: gpsd and gpsd-clients (gpsd reads
# the NMEA the package writes). Installed when missing (root, as on CI).
system-packages:
	command -v gpsd >/dev/null && command -v gpspipe >/dev/null || \
		(apt-get update -qq && apt-get install -y -qq --no-install-recommends gpsd gpsd-clients)

# Regenerate docs/calibration.md and docs/calibration/ from the measured traces.
calibration-doc: setup
	$(PY) tools/calibration_doc.py --data $(DATA) --out docs
	$(PY) tools/evidence_summary.py calibration.md

# The page again from its template (tools/templates/calibration.md) and the JSON in
# docs/calibration/, without fitting: after editing the words.
calibration-page: setup
	$(PY) tools/calibration_doc.py --render --out docs
	$(PY) tools/evidence_summary.py calibration.md

# The built-in profile snapshot-receiver-on-foot and docs/walks.md, from the
# SnapperGPS walks of data/ (about two minutes).
# The built-in preset phone-suburban-drive, its held-out checks (docs/presets/)
# and docs/presets.md, from the GSDC drives of data/ (about a minute).
presets: setup
	$(PY) tools/presets.py --data $(DATA) --out .

walks-profile: setup
	$(PY) tools/walks_profile.py --data $(DATA) --out .

# docs/model.md and its figure: the presets' typical errors and two
# recordings no fit saw beside simulated traces (about ten seconds).
model-page: setup
	$(PY) tools/model_page.py --data $(DATA) --out .

# The documentation site into site/ (MkDocs, strict: no broken link, no page left out).
docs: setup
	$(PY) tools/docs_index.py
	NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict

# The built site as a reader opens it from disk: headless Chromium (Debian's
# package, installed here if missing) screenshots the main pages at 1280 px
# into site_screenshots/, then lists every table or code block that scrolls
# sideways and searches the site from disk (tools/site_check.py).
site-screenshots: docs
	command -v chromium >/dev/null || (apt-get update -qq && apt-get install -y -qq chromium)
	$(PY) tools/site_screenshots.py --site site --out site_screenshots
	$(PY) tools/site_check.py --site site

# docs/generalisation.md: every class judged on folds across stretches, recordings
# and receivers of data/, GTSAM's smoother among the consumers (about 20 minutes).
generalisation: setup
	$(PY) tools/generalisation.py --data $(DATA) --out .
	$(PY) tools/evidence_summary.py generalisation.md

# The page again from its template (tools/templates/generalisation.md) and the JSON in
# docs/generalisation/, without fitting: after editing the words.
generalisation-page: setup
	$(PY) tools/generalisation.py --from-json --data $(DATA) --out .
	$(PY) tools/evidence_summary.py generalisation.md

# gpsd (Debian's gpsd and gpsd-clients, installed here if missing) reads the NMEA
# that gps_error simulate writes, streamed on loopback, and the error node's own
# NMEA stream (nmea_port), and states the same fixes (test/traces/test_gpsd.py,
# test/ros/test_nmea_node.py; make test runs them where gpsd is installed).
gpsd-check: setup
	command -v gpsd >/dev/null && command -v gpspipe >/dev/null || \
		(apt-get update -qq && apt-get install -y -qq --no-install-recommends gpsd gpsd-clients)
	$(PY) -m pytest -p no:cacheprovider test/traces/test_gpsd.py test/ros/test_nmea_node.py

# Benchmarks: figures printed (and kept in bench_output/), not timed tests.
# 40 to 80 minutes on a 2-core machine of the kind (its CPU decides; the Parquet
# benchmark adds about 6, the ns-3 study's cost about 15); see docs/performance.md.
bench: setup
	mkdir -p bench_output
	$(PY) bench/bench_library.py --json bench_output/library.json
	$(PY) bench/bench_node.py --json bench_output/node.json
	$(PY) bench/bench_simulate_fcd.py --json bench_output/simulate_fcd.json
	$(PY) bench/bench_simulate_parquet.py --json bench_output/simulate_parquet.json
	$(PY) bench/bench_zones.py --json bench_output/zones.json
	$(PY) bench/bench_long_recording.py --json bench_output/long_recording.json
	$(PY) bench/bench_p2v.py --json bench_output/p2v.json

# Soak (not part of make test, which runs 5-minute versions of both): 24
# simulated hours for 100 agents, then one simulated hour for 1,000 agents, as
# fast as the node keeps up; then 2 simulated hours of churn with agent_pattern
# (about 50 agents at a time, each living 1-10 minutes, one in five coming
# back). About 35 minutes on a 2-core machine (1064 s + 499 s + 480 s).
soak: setup
	mkdir -p bench_output
	$(PY) bench/soak.py --agents 100 --hours 24 --json bench_output/soak100.json
	$(PY) bench/soak.py --agents 1000 --hours 1 --sample-s 600 --window-s 900 \
		--json bench_output/soak1000.json
	$(PY) bench/soak_churn.py --concurrent 50 --hours 2 --json bench_output/soak_churn.json

# Blind diagnosis of synthetic walks: 100 seeds per effect-free scenario
# (false alarms against a binomial bound) and 20 per effect (attribution
# rate, and how often the cross-validated selection keeps the right effects).
# About 12 minutes on a 2-core machine (711 s with the street_canyon scenario); see
# docs/close-the-loop.md.
diagnose-long: setup
	mkdir -p bench_output
	$(PY) bench/diagnose_long.py --json bench_output/diagnose_long.json

# calibrate, validate, diagnose and compare on altered copies of every recording
# of data/ (cut, thinned, gappy, failing): each exits 0 quietly or
# refuses in one line. About 25 minutes on a 2-core machine.
input-sweep: setup
	$(PY) bench/input_sweep.py --data $(DATA)

# Regenerate docs/close-the-loop.md and docs/close-the-loop/ from the traces.
close-the-loop-doc: setup
	$(PY) tools/close_loop_doc.py --data $(DATA) --out docs
	$(PY) tools/evidence_summary.py close-the-loop.md

# The page again from its templates (tools/templates/close_loop*.md) and the JSON in
# docs/close-the-loop/, without diagnosing: after editing the words.
close-the-loop-page: setup
	$(PY) tools/close_loop_doc.py --render --out docs
	$(PY) tools/evidence_summary.py close-the-loop.md

lint: setup
	$(PY) -m pytest -m linter

clean:
	rm -rf $(VENV) build install log $(DEMO_OUT) *.egg-info
