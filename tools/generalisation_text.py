"""
The fixed prose of ``docs/generalisation.md``, and the classes' names on it.

:mod:`generalisation` writes the page: its figures and the sentences read
from them there, the paragraphs that never change here.
"""

#: What the page calls each class of :mod:`gps_error_ros.judge.generalise`.
LABELS = {'white_bias': 'white noise + bias', 'ar1': 'AR(1)', 'arma11': 'ARMA(1,1)',
          'ar3_paper': 'AR(3), paper', 'ar_p': 'AR(p), PACF', 'extended': 'extended',
          'population_ar': 'population (Gaussian AR within)',
          'population': 'population (extended within)'}


PAGE_HEAD = """# Generalisation: each class on data its fit did not see

What a simulator fitted on one stretch does on another stretch, another
recording and another receiver. Every class is fitted on the training part
of each fold and judged on its held-out part (`gps_error compare --folds`,
method in `gps_error_ros/judge/generalise.py`):

- **held-out NLL**: the one-step predictive negative log density per
  sample (a proper score; lower is better), mean over folds; **best**: the
  folds on which the class had the lowest (a tie counts for each: a
  population class whose training part has too few blocks for a section
  is the class it wraps); **- population (<, >)**: the class's NLL minus
  the population class's (extended within), paired on the same held-out
  samples, mean over folds, and the folds on which the difference lies
  below (<) or above (>) 0 beyond its 95 % interval (a moving-block
  bootstrap of the per-sample differences, blocks of 30 samples): a
  difference whose interval holds 0 is one the held-out samples cannot
  resolve;
- **groups**: the share of a group's measures whose held-out value lies
  inside the central 95 % range of {sims} traces simulated along the
  held-out truth, mean over folds (near 0.95 for a simulator that holds):
  persistence (ACF lag 1, lag 10, integral time scale per axis), scale (SD
  per axis, north-east correlation), bias (mean per axis), quantiles
  (horizontal 50/68/95/99 %), tails (share of steps beyond the training
  part's 99 % step, the 99 % step), filter (a constant-velocity Kalman
  filter with a velocity aid: RMS, 95 % error, NEES, gate rejections),
  v2p (conflicts warned, false warnings), outages where a fold has them
  (number, steps in outages, median and longest; availability fitted on the
  training gaps for the extended and population classes, none for the
  others; on the walks these are the gaps that removed gross failures leave)
  and smoother (GTSAM's iSAM2 with
  GPS and odometry factors on the first 600 held-out samples: the newest
  pose's RMS and 95 % error, the smoothed track's RMS; judged on 40 of the
  simulated traces, for four classes: "-" for the others). Where a trace
  has the phone's and the reference's speed and course, a table under its
  set judges the profile's `velocity` section by band of the true speed
  (speed error mean and SD, median absolute course error); every class
  shares that section.
- **worst, own %**: the class's worst group (over the groups every
  simulated trace has: not the smoother's) and how often a trace of the
  class's own, judged as the real one is, has its worst group as low or
  lower (the k-th simulated trace of each fold together make one set of
  folds from the model; below 5 % the real trace is unlike the class's
  own); **own at 0.90**: how often the class's own traces have every such
  group at 0.90 or more, the bar a perfect simulator would have to clear.

The population classes are the profile that `calibrate --population
--within ar` writes (Gaussian AR within blocks of 300 s) and the same
section on the extended model fitted within blocks (`calibrate
--population`, or `diagnose --profile-out --population` on the training part):
each simulated agent draws its own bias (and its wander) and scale from the
spread of the training blocks.

Regenerate with `make generalisation` (`DATA=folder`: the recordings to
judge; the repository's `data/` by default; this page was made with the
UrbanNav recording beside them, which is not shipped): every
recording there but the walks is judged alone by rolling origin, the walks
leave one out, and a recording too short for a fold to hold out 60 samples
is named under "Not judged".
Measured on {date}, {machine}; {minutes:.0f} minutes.
"""


CAUSES_HEAD = """## Why a profile of one stretch does not transfer

Five causes, told apart by the folds (figures of this run, per set): (a) a
slow wander of the bias that one stretch cannot estimate; (b) scale and
persistence that change with the environment between training and held-out
parts; (c) differences between receivers, in bias and in dynamics (the GSDC
phones of one drive: the set's own table, and where a simpler class scores
better, below) against differences between occasions (three of the walks
are one walk with three receivers, whose mean errors agree within half a
metre while separate walks differ by metres: the bias is the occasion's, and
the population fit counts an occasion once,
[decision 0007](decisions/0007-occasions.md)); (d) tails and jumps that a
Gaussian process under-simulates (the filter's gate); (e) a selection that
fits one split (the extended class's NLL against its groups). And (f), what
the bar itself asks: groups of two to four measures are coarse, so a trace
of a class's own has some group below 0.90 more often than not (column *own
at 0.90* of each set's table); the worst group's percentile among the
class's own traces says whether a miss is evidence against the class.
"""

BEATEN_HEAD = """## Where a simpler class scores better than the population

The folds on which a class's held-out NLL lies below the population class's
beyond its 95 % interval, and where: the held-out samples cut into blocks in
time order, split by how far each block's mean error lies from the
population's mean in its bias SDs (a gain where the held-out level is far
would say the population's bias law is too narrow for this data), and the
partial autocorrelation of the training and held-out errors (a structure at
lags beyond the first that one part has and the other lacks is dynamics that
a class with more lags carries over and one with fewer does not). The AR
order that each part's own 300-s blocks choose, each block predicted from
the others, tells which: lags that predict every block of the training part
are its dynamics; lags that only the part as a whole supports are a fit to
that split.
"""

EXPLAIN_HEAD = """## How the held-out parts differ from what trained

Each fold's training part against its held-out part (training / held out):
the SD and lag-1 autocorrelation per axis and the mean error per axis. A
profile fitted on the training part describes its left column; a stationary
profile can only hold where the right column is a draw of the same process.
Below each, the share of fixes the filter's gate rejects on the real
held-out fixes, against the range each class simulates.
"""

FILTER_HEAD = """
Where the population class's filter measures miss their range, a second
table says what the filter's error is made of: over a held-out part a
filter that averages many fixes errs by about the error's mean, plus what
it lets through of the error about that mean. So, against the class's
simulated traces (with the measured value's percentile among them): the
filter's RMS error; the size of the error's mean (both axes together; each
axis alone is in the bias group); the error's SD; and the filter's RMS on
the error less its mean, divided by that SD (its response to the error's
dynamics, whatever their scale). When the last is inside, the filter sees
nothing the first two do not explain: a mean that lands near zero is rare
in two dimensions even when each axis's mean is central, and a small mean
with a small SD make a calm filter together.
"""

SPREAD_HEAD = """
A third table asks whether the training part itself held stretches of
different persistence: each 300-s block's lag-1 autocorrelation (about the
block's mean), their SD over the blocks and their lowest value, against the
same figures of the population's traces simulated on the training samples.
The population draws each agent's bias and scale, but all its agents share
one process and so one persistence: an SD above its range says the
recording's stretches differ in persistence more than that process's
stretches do by chance, which no draw of bias or scale mends (why none of
persistence is drawn:
[decision 0022](decisions/0022-one-persistence-for-every-agent.md)). A fold
with fewer than three blocks, or without a population section, has no row.
"""

PRECEDENT_HEAD = """
The error measures on which the population class (extended within) misses
its simulated 95 % range, and of those the ones without precedent: outside
their range over the training part's own windows of the held-out part's
span (stepped by half of it; a training recording shorter than that, whole).
A stationary profile fitted on that part has no stretch like it to learn
from:
"""
