"""Reported speed and course: the velocity error process, and calibrate's fit of it."""

import numpy as np
import pytest

from gps_error_ros.cli import main as cli
from gps_error_ros.model import streams
from gps_error_ros.model.profiles import load_profile, load_profile_file, ProfileError
from gps_error_ros.model.velocity import velocity_from_dict
from gps_error_ros.sim.simulate import simulate_csv
from trace_helpers import write_drive
from measured import DATA

TRUE = {'sigma': 0.15, 'phi': 0.7, 'lag_s': 0.7, 'standstill': 0.0}


def _fitted(tmp_path, velocity, steps=1500):
    """Return the section calibrate fits to ``velocity`` simulated on a drive of ``steps`` s."""
    write_drive(tmp_path / 'truth.csv', steps=steps)        # 1 to 13 m/s, turning
    simulate_csv(tmp_path / 'truth.csv', tmp_path / 'noisy.csv', load_profile('DS1').model(),
                 1.0, 5, velocity)
    assert cli(['calibrate', str(tmp_path / 'noisy.csv'), '-o', str(tmp_path / 'p.yaml'),
                '--order', '3']) == 0
    return load_profile_file(tmp_path / 'p.yaml').velocity


def test_the_error_process_and_what_the_phone_reports():
    v = velocity_from_dict(TRUE)
    keys = streams.agent_keys(2, [f'a{i}' for i in range(400)])
    w = v.errors(keys, 300, start=20)                       # (steps, agents, 2)
    n = w[:, :, 0].size
    assert abs(w.std() - 0.15) < 5 * 0.15 / np.sqrt(n / 6)    # ~6 steps per independent value
    r1 = np.sum(w[1:] * w[:-1]) / np.sum(w[:-1] ** 2)
    assert abs(r1 - 0.7) < 0.02
    alone = v.errors(keys[7:8], 300, start=20)
    np.testing.assert_array_equal(alone[:, 0], w[:, 7])       # each agent its own stream
    speed, course = v.report(np.array([[0.0, 1.4], [0.0, 0.0], [3.0, 0.0]]), w[5, :3])
    assert speed[1] == 0 and np.isnan(course[1])              # standstill: 0, no course
    assert (speed >= 0).all() and 0 <= course[2] < 360
    # the course error grows as the walker slows: about sigma / speed radians
    walk = np.zeros((400, 2))
    walk[:, 1] = 1.4
    _, c = v.report(walk, w[100])
    spread = np.degrees(np.sqrt(np.mean(np.radians((c + 180) % 360 - 180) ** 2)))
    assert abs(spread - np.degrees(0.15 / 1.4)) < 2.0


def test_a_speed_table_scales_the_same_stream():
    plain = velocity_from_dict(TRUE)
    table = velocity_from_dict(dict(TRUE, sigma_by_speed=[[2.0, 0.4], [12.0, 0.1]]))
    keys = streams.agent_keys(2, [f'a{i}' for i in range(4000)])
    w = plain.errors(keys, 3, start=5)[-1]
    assert np.array_equal(table.errors(keys, 3, start=5)[-1], w)   # one stream, one sigma
    for speed, sd in ((1.0, 0.4), (7.0, 0.25), (30.0, 0.1)):      # flat outside, linear inside
        v_true = np.tile([0.0, speed], (keys.size, 1))
        err = np.stack(v_true + table.scaled(v_true, w) - v_true)
        assert table.sd_at(speed) == pytest.approx(sd)
        np.testing.assert_allclose(err, w * sd / 0.15, atol=1e-14)
        assert abs(err.std() - sd) < 4 * sd / np.sqrt(2 * keys.size)
    assert plain.scaled(v_true, w) is w                     # no table: the error untouched
    assert table.to_dict()['sigma_by_speed'] == [[2.0, 0.4], [12.0, 0.1]]
    assert velocity_from_dict(table.to_dict()) == table


def test_an_agents_scale_multiplies_its_whole_error_stream():
    """``scale_sd_log``: each agent its own multiple of the error; without it, bit for bit."""
    plain = velocity_from_dict(TRUE)
    scaled = velocity_from_dict(dict(TRUE, scale_sd_log=0.3))
    keys = streams.agent_keys(2, [f'a{i}' for i in range(4000)])
    w0, w = plain.errors(keys, 20, start=5), scaled.errors(keys, 20, start=5)
    # the initial error and every innovation: one factor per agent, at every step
    z = streams.normal_pairs(keys, streams.DOMAIN_VELOCITY_SCALE, 0)[:, 0]
    f = np.exp(0.3 * z - 0.09)
    np.testing.assert_allclose(w, f[None, :, None] * w0, rtol=0, atol=1e-14)
    assert abs(np.std(np.log(f)) - 0.3) < 0.02
    assert abs(np.mean(f ** 2) - 1.0) < 0.03            # the agents' average variance kept
    assert scaled.sd_at(7.0) == plain.sd_at(7.0)        # the published SD: the population's
    # an agent's scale is its own: alone, in a crowd, from any start step
    np.testing.assert_array_equal(scaled.errors(keys[9:10], 20, start=5)[:, 0], w[:, 9])
    np.testing.assert_allclose(scaled.errors(keys[:50], 3, start=400),
                               f[None, :50, None] * plain.errors(keys[:50], 3, start=400),
                               rtol=0, atol=1e-14)
    # no key (or the node's step by step): the stream as it always was
    assert velocity_from_dict(dict(TRUE, scale_sd_log=0.0)).errors(keys, 3)[2] == \
        pytest.approx(plain.errors(keys, 3)[2], rel=1e-15)
    w_step = plain.initial(keys, 5)
    for k in range(6, 25):
        w_step = plain.step(w_step, keys, k)
    assert np.array_equal(w_step, w0[-1])
    # stepped by turns with two sets of agents (the scales it keeps are each set's own)
    one, other = keys[:7], keys[7:20]
    w_one, w_other = scaled.initial(one, 5), scaled.initial(other, 5)
    for k in range(6, 25):
        w_one, w_other = scaled.step(w_one, one, k), scaled.step(w_other, other, k)
    assert np.array_equal(np.r_[w_one, w_other], w[-1, :20])
    assert scaled.to_dict()['scale_sd_log'] == 0.3 and 'scale_sd_log' not in plain.to_dict()
    assert velocity_from_dict(scaled.to_dict()) == scaled


def test_bursts_make_the_error_heavy_tailed_and_keep_its_sd():
    """``burst_share`` / ``burst_ratio``: a share of the innovations larger; the SD the same."""
    plain = velocity_from_dict(TRUE)
    burst = velocity_from_dict(dict(TRUE, phi=0.2, burst_share=0.05, burst_ratio=6.0))
    keys = streams.agent_keys(3, [f'a{i}' for i in range(2000)])
    w = burst.errors(keys, 200)                        # (steps, agents, 2)
    assert abs(w.std() - 0.15) < 0.003                 # the section's SD, as without bursts
    x = w[1:] - 0.2 * w[:-1]                           # the innovations
    x = x / x.std()
    kurt = float(np.mean(x ** 4))
    c0 = 1 / np.sqrt(1 - 0.05 + 0.05 * 36)             # mixture: 3 (0.95 c0^4 + 0.05 (6 c0)^4)
    assert abs(kurt - 3 * c0 ** 4 * (0.95 + 0.05 * 6 ** 4)) < 1.5, kurt
    # beyond 4 SDs only in a burst (SD 3.6 there, 0.6 else): 5 % x 47 % of the steps; and
    # both components at once (one uniform per agent and step): 27 % of those, not 1 %
    big = np.abs(x) > 4
    assert 0.017 < np.mean(big[..., 0] | big[..., 1]) < 0.03
    assert np.mean(big[..., 0] & big[..., 1]) > 0.2 * np.mean(big[..., 0])
    np.testing.assert_array_equal(burst.errors(keys[4:5], 200)[:, 0], w[:, 4])
    assert velocity_from_dict(burst.to_dict()) == burst
    assert 'burst_share' not in plain.to_dict()
    assert np.array_equal(velocity_from_dict(dict(TRUE)).errors(keys, 5), plain.errors(keys, 5))


def test_the_bursts_are_fitted_from_the_errors_shape():
    from gps_error_ros.fit.velocity_fit import fit_bursts
    rng = np.random.default_rng(5)
    n = 40000
    c0 = 1 / np.sqrt(1 - 0.06 + 0.06 * 25)
    x = rng.standard_normal(n) * np.where(rng.random(n) < 0.06, 5 * c0, c0)
    share, ratio = fit_bursts(x)
    assert share == pytest.approx(0.06, abs=0.015) and ratio == pytest.approx(5.0, rel=0.15)
    assert fit_bursts(rng.standard_normal(n)) is None           # normal: no bursts
    assert fit_bursts(x[:50]) is None                             # too few values


@pytest.mark.parametrize('share, ratio', [(3e-6, 40.0), (0.6, 3.0), (0.05, 1.00004),
                                          (0.05, 150.0)])
def test_bursts_outside_the_schema_once_rounded_are_not_written(share, ratio):
    """A share of a few millionths rounds to 0: calibrate wrote it; its profile did not load."""
    from gps_error_ros.fit.velocity_fit import bursts_as_written
    assert bursts_as_written(share, ratio) is None
    p, r = bursts_as_written(0.0123456, 6.54321)
    velocity_from_dict(dict(TRUE, burst_share=p, burst_ratio=r))      # loads


def test_a_heavy_tailed_error_of_one_scale_has_no_scale_beyond_sampling():
    """The sampling of a block's RMS follows the kurtosis within the blocks."""
    from gps_error_ros.fit.velocity_fit import block_scale
    burst = velocity_from_dict(dict(TRUE, phi=0.3, burst_share=0.05, burst_ratio=7.0))
    u = burst.errors(streams.agent_keys(6, ['one']), 12000)[:, 0] / 0.15
    got = block_scale(u, np.arange(12000.0), 0.3)
    assert got['kurtosis_within'] > 10 and got['beyond_sampling_sd'] < 0.08, got
    assert got['sampling_sd'] > 0.06                  # a normal error's would be 0.03


def test_calibrate_recovers_the_agents_scale_from_the_stretches():
    """40 stretches of 300 s, each another agent of a section with ``scale_sd_log`` 0.3."""
    from gps_error_ros.fit.velocity_fit import estimate_velocity, residuals
    from gps_error_ros.traces.trace_io import Trace
    truth = velocity_from_dict(dict(TRUE, lag_s=0.0, scale_sd_log=0.3))
    keys = streams.agent_keys(4, [f'stretch{i}' for i in range(40)])
    w = truth.errors(keys, 300).transpose(1, 0, 2).reshape(-1, 2)     # one stretch after another
    t = np.arange(w.shape[0], dtype=float)
    phone = np.array([0.0, 10.0]) + w                       # 10 m/s north, and its error
    zeros = np.zeros(t.size)
    trace = Trace('stretches', t, zeros, zeros, zeros, zeros, extra={
        'truth_speed': np.full(t.size, 10.0), 'truth_bearing': zeros,
        'speed': np.hypot(phone[:, 0], phone[:, 1]),
        'bearing': np.degrees(np.arctan2(phone[:, 0], phone[:, 1])) % 360.0})
    fitted = estimate_velocity(trace)
    section, evidence = fitted.section, fitted.evidence
    between = evidence['scale_between_blocks']
    assert between['blocks'] == 40
    assert section['scale_sd_log'] == between['beyond_sampling_sd']
    assert 0.22 < section['scale_sd_log'] < 0.38, between
    assert section['phi'] == pytest.approx(0.7, abs=0.05)
    moving, v_true, left = residuals(trace, section)      # the error the fit measured
    assert moving.all() and left.shape == w.shape
    np.testing.assert_allclose(v_true, np.tile([0.0, 10.0], (t.size, 1)), atol=1e-9)
    assert np.sqrt(np.mean(left ** 2)) == pytest.approx(section['sigma'], abs=1e-6)
    np.testing.assert_allclose(left[:, 0], w[:, 0], atol=1e-9)     # across: nothing taken off


def test_a_course_lag_turns_the_speed_lags_truth_and_nothing_else():
    plain = velocity_from_dict(TRUE)
    both = velocity_from_dict(dict(TRUE, course_lag_s=1.0))
    assert plain.lags == (0.7,) and both.lags == (0.7, 1.0)
    v_speed = np.array([[3.0, 4.0], [3.0, 4.0], [3.0, 4.0], [np.nan, np.nan], [0.0, 0.0]])
    v_course = np.array([[0.0, 2.0], [0.0, 0.0], [np.nan, np.nan], [1.0, 0.0], [1.0, 0.0]])
    assert plain.truth_reported(v_speed, v_course) is v_speed       # no course lag: as before
    got = both.truth_reported(v_speed, v_course)
    np.testing.assert_array_equal(got[0], [0.0, 5.0])   # the speed's 5 m/s, the course's north
    np.testing.assert_array_equal(got[1], [3.0, 4.0])   # the course's truth stands: the speed's
    assert np.isnan(got[2:4]).all()                     # either truth unknown: none
    np.testing.assert_array_equal(got[4], [0.0, 0.0])   # standing at the speed's lag: standing
    assert both.to_dict()['course_lag_s'] == 1.0 and velocity_from_dict(both.to_dict()) == both
    assert 'course_lag_s' not in plain.to_dict()


def test_calibrate_tells_the_course_lag_from_the_speed_lag(tmp_path):
    # the drive speeds up, slows down and turns; a small error lets the course show
    got = _fitted(tmp_path, velocity_from_dict(dict(TRUE, sigma=0.05, phi=0.3, course_lag_s=0.9)),
                  steps=3000)
    # (1-s chords: the speed 0.7 s late, the course's chord centred 0.9 s before)
    assert (got.lag_s, got.course_lag_s) == (pytest.approx(0.7), pytest.approx(0.9)), got
    assert got.sigma == pytest.approx(0.05, rel=0.2)


def test_a_speed_bias_moves_the_speed_along_the_track_and_never_below_zero():
    biased = velocity_from_dict(dict(TRUE, speed_bias=[[2.0, -0.5], [12.0, 0.5]]))
    v_true = np.array([[0.0, 7.0], [3.0, 4.0], [0.0, 0.3], [0.0, 0.0], [0.0, 20.0]])
    got = biased.biased(v_true)
    np.testing.assert_allclose(got[0], [0.0, 7.0])            # halfway: no bias
    np.testing.assert_allclose(got[1], np.array([3.0, 4.0]) * 4.8 / 5.0)   # -0.2 m/s
    np.testing.assert_array_equal(got[2:4], 0.0)               # 0.3 - 0.5: stands, no reverse
    np.testing.assert_allclose(got[4], [0.0, 20.5])            # flat beyond the last speed
    w = np.zeros((5, 2))
    np.testing.assert_allclose(biased.vector(v_true, w)[0], got)   # what the phone reports
    plain = velocity_from_dict(TRUE)
    assert plain.biased(v_true) is v_true and 'speed_bias' not in plain.to_dict()
    assert velocity_from_dict(biased.to_dict()) == biased


def test_the_one_pass_gives_the_reported_velocity_and_its_mean_as_the_two_calls_do():
    section = velocity_from_dict(dict(TRUE, speed_bias=[[2.0, -0.5], [12.0, 0.5]],
                                      sigma_by_speed=[[1.0, 0.3], [10.0, 0.1]]))
    v_true = np.array([[0.0, 7.0], [3.0, 4.0], [0.0, 0.3], [0.0, 0.0], [np.nan, np.nan]])
    w = np.random.default_rng(3).normal(size=(5, 2))
    v, still, mean = section.vector_and_mean(v_true, w)
    want_v, want_still = section.vector(v_true, w)
    np.testing.assert_array_equal(v, want_v)
    np.testing.assert_array_equal(still, want_still)
    np.testing.assert_array_equal(mean, section.mean_error(v_true))
    assert np.isnan(v[4]).all() and not still[4]                  # unknown truth: unknown
    np.testing.assert_allclose(mean[1], np.array([3.0, 4.0]) * -0.2 / 5.0)
    # the node's pass: the same, composed of the parts, with the SD at the true speed
    *parts, sd = section.report_parts(v_true, w)
    speed = np.hypot(v_true[:, 0], v_true[:, 1])
    assert np.array_equal(sd, section.sd_at(speed), equal_nan=True)
    composed = section.biased(v_true, speed) + section.scaled(v_true, w, speed)
    np.testing.assert_array_equal(parts[0][:3], composed[:3])   # (row 3 stands still: 0)
    plain = velocity_from_dict(TRUE)                            # no speed bias: no mean to take
    v, still, mean = plain.vector_and_mean(v_true, w)
    assert mean is None
    np.testing.assert_array_equal(v, plain.vector(v_true, w)[0])


def test_calibrate_recovers_a_speed_bias(tmp_path):
    bias = [[2.0, 0.2], [12.0, -0.3]]
    got = _fitted(tmp_path, velocity_from_dict(dict(TRUE, sigma=0.1, speed_bias=bias)), 3000)
    assert len(got.speed_bias) >= 3, got
    for speed in (3.0, 5.0, 8.0, 11.0):
        want = float(np.interp(speed, *np.array(bias).T))
        assert abs(float(np.interp(speed, *np.array(got.speed_bias).T)) - want) < 0.04, got
    assert got.sigma == pytest.approx(0.1, rel=0.15)    # the bias is not taken for error


def test_a_speed_bias_is_the_mean_along_the_track_not_the_mean_speed_error():
    # A walker at 2 m/s whose phone errs 0.6 m/s per component, without bias: its
    # speed is on average sigma^2 / (2 speed) = 0.09 m/s too high (the error across
    # the track only lengthens the vector); the fitted bias must not take that for one.
    from gps_error_ros.fit.velocity_fit import estimate_velocity
    from gps_error_ros.traces.trace_io import Trace
    rng = np.random.default_rng(5)
    t = np.arange(20000.0)
    east, north = rng.normal(0.0, 0.6, t.size), 2.0 + rng.normal(0.0, 0.6, t.size)
    zeros = np.zeros(t.size)
    trace = Trace('walk', t, zeros, zeros, zeros, zeros, extra={
        'truth_speed': np.full(t.size, 2.0), 'truth_bearing': zeros,
        'speed': np.hypot(east, north), 'bearing': np.degrees(np.arctan2(east, north)) % 360})
    section = estimate_velocity(trace).section
    assert np.mean(trace.extra['speed']) - 2.0 > 0.07              # the speed's mean error
    assert [b for _, b in section['speed_bias']] == [pytest.approx(0.0, abs=0.015)]
    assert section['sigma'] == pytest.approx(0.6, rel=0.02)


def test_calibrate_recovers_a_speed_table(tmp_path):
    velocity = velocity_from_dict(dict(TRUE, sigma_by_speed=[[2.0, 0.4], [12.0, 0.1]]))
    got = _fitted(tmp_path, velocity, steps=3000)
    assert len(got.sigma_by_speed) >= 3, got
    for speed in (2.5, 5.0, 8.0, 11.0):
        assert got.sd_at(speed) == pytest.approx(velocity.sd_at(speed), rel=0.2), got
    assert got.phi == pytest.approx(0.7, abs=0.08)      # of the error in units of its SD


def test_calibrate_recovers_a_known_velocity_section(tmp_path):
    got = _fitted(tmp_path, velocity_from_dict(TRUE))
    header = (tmp_path / 'noisy.csv').read_text().splitlines()[0].split(',')
    assert {'speed', 'bearing', 'accuracy', 'accuracy_major'} <= set(header)   # both kinds
    assert got.lag_s == pytest.approx(0.7)     # (below 0.5 s a 1-s chord ending at t acts as 0.5)
    # one lag for both: the course's is found near it (this drive turns gently, and its
    # error, persistent, hides a few tenths of a second; with a smaller error the
    # course's own lag is found to the step, test_calibrate_tells_the_course_lag_...)
    assert 0.4 <= got.course_lag_s <= 1.0, got
    assert got.sigma == pytest.approx(0.15, rel=0.15)
    assert got.phi == pytest.approx(0.7, abs=0.08)


@pytest.mark.parametrize('name, speed_lag, course_lag', [
    ('gsdc2020-mtv1-pixel4.csv', (0.2, 0.4), (0.5, 0.7)),         # the course lags more
    ('gsdc2020-mtv1-pixel4xlmodded.csv', (0.6, 0.8), (0.2, 0.4)),  # the speed lags more
])
def test_the_measured_phones_speed_and_course_lag_apart_and_err_decimetres(
        tmp_path, name, speed_lag, course_lag):
    assert cli(['calibrate', str(DATA / name), '-o', str(tmp_path / 'p.yaml'),
                '--order', '3']) == 0
    fitted = load_profile_file(tmp_path / 'p.yaml')
    v = fitted.velocity
    assert speed_lag[0] <= v.lag_s <= speed_lag[1], v
    assert course_lag[0] <= v.course_lag_s <= course_lag[1], v
    assert 0.05 < v.sigma < 0.3 and 0.0 < v.phi < 0.9, v
    # town errs several times more than the open road (decimetres against centimetres)
    assert v.sd_at(7.0) > 0.4 and v.sd_at(27.0) < 0.12 and v.sd_at(7.0) > 4 * v.sd_at(27.0), v
    assert fitted.fit['velocity']['moving_rows'] > 1500


@pytest.mark.parametrize('section, expected', [
    ({'sigma': 0.1, 'phi': 0.5}, r'velocity.lag_s is missing'),
    ({'sigma': 0.0, 'phi': 0.5, 'lag_s': 0.0, 'standstill': 0.0}, 'velocity.sigma'),
    ({'sigma': 0.1, 'phi': 1.0, 'lag_s': 0.0, 'standstill': 0.0}, 'velocity.phi'),
    ({'sigma': 0.1, 'phi': 0.5, 'lag_s': -1, 'standstill': 0.0}, 'velocity.lag_s'),
    (dict(TRUE, course_lag_s=11.0), 'velocity.course_lag_s'),
    (dict(TRUE, course_lag_s='late'), 'velocity.course_lag_s'),
    (dict(TRUE, speed_bias=[[5.0, -0.2], [3.0, 0.1]]), "speed_bias.*increasing"),
    (dict(TRUE, speed_bias=[[5.0, -200.0]]), r'speed_bias.*values in \(-100, 100\)'),
    (dict(TRUE, sigma_by_speed=[[5.0, 0.2], [5.0, 0.1]]), r'increasing.*got \[\[5.0, 0.2\]'),
    (dict(TRUE, sigma_by_speed=[[5.0, 0.0]]), r'values in \(0, 100\).*got \[\[5.0, 0.0\]\]'),
    (dict(TRUE, sigma_by_speed=[[5.0, float('nan')]]), 'sigma_by_speed'),
    (dict(TRUE, sigma_by_speed=[]), 'sigma_by_speed'),
    (dict(TRUE, sigma_by_speed='fast'), 'sigma_by_speed'),
    (dict(TRUE, extra=1), 'velocity.extra is not a key of it'),
    (dict(TRUE, scale_sd_log=-0.1), r'velocity.scale_sd_log: expected a number in \[0, 2\]'),
    (dict(TRUE, scale_sd_log=2.5), 'velocity.scale_sd_log'),
    (dict(TRUE, scale_sd_log=True), 'velocity.scale_sd_log'),
    (dict(TRUE, scale_sd_log='wide'), 'velocity.scale_sd_log'),
    (dict(TRUE, burst_share=0.05), 'expected both or neither'),
    (dict(TRUE, burst_share=0.6, burst_ratio=4.0), r'burst_share: expected a number in \(0, 0\.5'),
    (dict(TRUE, burst_share=0.05, burst_ratio=1.0), r'burst_ratio: expected a number in \(1, 100'),
    (dict(TRUE, burst_share='few', burst_ratio=4.0), 'burst_share'),
])
def test_a_bad_section_is_refused_naming_the_key(section, expected):
    from gps_error_ros.model.profiles import profile_from_dict
    raw = {'schema': 1, 'name': 'v', 'description': 'd', 'source': 's', 'rate_hz': 1.0,
           'velocity': section}
    with pytest.raises(ProfileError, match=expected):
        profile_from_dict(raw, 'v.yaml')


def test_implausible_speeds_and_courses_are_left_out_and_counted():
    from gps_error_ros.fit.velocity_fit import estimate_velocity
    from gps_error_ros.traces.trace_io import read_trace_csv
    trace = read_trace_csv(DATA / 'gsdc2020-mtv1-pixel4.csv')
    clean = estimate_velocity(trace).section
    rng = np.random.default_rng(3)
    hit = {k: rng.random(len(trace)) < 0.02 for k in ('speed', 'truth_speed', 'bearing')}
    trace.extra['speed'][hit['speed']] = 1e9
    trace.extra['truth_speed'][hit['truth_speed']] = -1.0
    trace.extra['bearing'][hit['bearing']] = 720.0
    fitted = estimate_velocity(trace)
    got, evidence = fitted.section, fitted.evidence
    assert evidence['implausible_rows'] == int((hit['speed'] | hit['truth_speed']
                                                | hit['bearing']).sum())
    assert got['sigma'] == pytest.approx(clean['sigma'], rel=0.1)
    # (the RMS is flat near its least: 2 % fewer rows may move the lag a step)
    assert abs(got['lag_s'] - clean['lag_s']) <= 0.1 and 0.0 <= got['standstill'] <= 2.0


def _turning_drive(name, start_deg, rng):
    """Return a 200-s recording at 10 m/s turning 30 degrees, its phone 0.5 s late, noisy."""
    from gps_error_ros.traces.trace_io import Trace
    t = np.arange(200.0)
    course = start_deg + 30.0 * t / t[-1]
    phone = np.interp(t - 0.5, t, course)           # held before the first sample
    zeros = np.zeros(t.size)
    return Trace(name, t, zeros, zeros, zeros, zeros,
                 extra={'truth_speed': np.full(t.size, 10.0), 'truth_bearing': course,
                        'speed': 10.0 + rng.normal(0.0, 0.05, t.size),
                        'bearing': phone % 360.0})


def test_a_velocitys_lag_never_reaches_back_into_the_recording_before():
    # The two recordings drive opposite ways; joined 100 s apart, a lag that
    # interpolated into the gap would blend the first's last velocity into the
    # second's first row. Each row's error is then what it is alone.
    from gps_error_ros.fit.velocity_fit import estimate_velocity
    from gps_error_ros.traces.trace_io import join_recordings
    rng = np.random.default_rng(11)
    north, south = _turning_drive('a', 0.0, rng), _turning_drive('b', 180.0, rng)
    alone = [estimate_velocity(tr).section for tr in (north, south)]
    joined = estimate_velocity(join_recordings([north, south])).section
    assert [s['course_lag_s'] for s in alone] == [0.5, 0.5] and joined['course_lag_s'] == 0.5
    assert joined['lag_s'] in [s['lag_s'] for s in alone]
    # (each alone has its own speed bias; joined, one: the two bias's spread adds)
    bias = [s['speed_bias'][0][1] for s in alone]
    pooled = np.sqrt(np.mean([s['sigma'] ** 2 + (b - np.mean(bias)) ** 2 / 2
                              for s, b in zip(alone, bias)]))
    assert joined['sigma'] == pytest.approx(pooled, abs=2e-6)


def test_the_scale_between_blocks_is_told_from_sampling():
    """40 blocks of 300 s whose scale has log SD 0.3 against one scale for all (AR(1), 0.5)."""
    from scipy.signal import lfilter

    from gps_error_ros.fit.velocity_fit import block_scale
    rng = np.random.default_rng(3)
    t = np.arange(12000.0)
    z = lfilter([np.sqrt(1 - 0.25)], [1.0, -0.5], rng.standard_normal((12000, 2)), axis=0)
    steady = block_scale(z, t, 0.5)
    assert steady['blocks'] == 40 and steady['beyond_sampling_sd'] < 0.05, steady
    # sampling alone: sqrt((1 + phi^2) / (1 - phi^2) / (4 * 300)) for blocks of 300 rows
    assert abs(steady['sampling_sd'] - np.sqrt(1.25 / 0.75 / 1200)) < 1e-4
    scale = np.exp(0.3 * np.repeat(rng.standard_normal(40), 300))
    varied = block_scale(z * scale[:, None], t, 0.5)
    assert 0.22 < varied['beyond_sampling_sd'] < 0.38, varied
    # rows not judged (NaN) are left out; fewer than three blocks of 60 rows: none
    z[:, 0][t >= 600] = np.nan
    assert block_scale(z, t, 0.5) is None


def test_calibrate_records_how_the_scale_moves_between_blocks(tmp_path):
    import yaml
    _fitted(tmp_path, velocity_from_dict(TRUE), steps=1800)
    fit = yaml.safe_load((tmp_path / 'p.yaml').read_text())['fit']['velocity']
    scale = fit['scale_between_blocks']
    # one scale for the whole drive: the blocks' spread is about what sampling gives
    assert scale['blocks'] == 6 and scale['beyond_sampling_sd'] < 0.15, scale
    section = yaml.safe_load((tmp_path / 'p.yaml').read_text())['velocity']
    assert section.get('scale_sd_log', 0.0) == scale['beyond_sampling_sd']
