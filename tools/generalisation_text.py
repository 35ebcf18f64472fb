"""
The classes' names on ``docs/generalisation.md`` (and its summary).

The page's words are the template ``tools/templates/generalisation.md``.
"""

#: What the page calls each class of :mod:`gps_error_ros.judge.generalise`.
LABELS = {'white_bias': 'white noise + bias', 'ar1': 'AR(1)', 'arma11': 'ARMA(1,1)',
          'ar3_paper': 'AR(3), paper', 'ar_p': 'AR(p), PACF', 'extended': 'extended',
          'population_ar': 'population (Gaussian AR within)',
          'population': 'population (extended within)'}
