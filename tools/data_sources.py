"""What each measured trace is, and its licence (for the docs; data/README.md: those shipped)."""

#: The SnapperGPS pedestrian walks among the traces (their own page: walks.md).
WALKS = 'snapper-walk-*.csv'

# Facts from data/README.md: what each trace is, and its licence.
CREDITS = {
    'gsdc2020-mtv1-pixel4.csv': (
        'Google Pixel 4, own location output; car, Mountain View CA',
        'Google Smartphone Decimeter Challenge 2020 (data by Google), drive '
        '2020-05-14-US-MTV-1, via the public repository AILocAR/androidGnss; '
        'repository licence Apache-2.0'),
    'gsdc2020-mtv1-pixel4xlmodded.csv': (
        'Pixel 4 XL (modified), own location output; same drive',
        'Google Smartphone Decimeter Challenge 2020 (data by Google), via '
        'AILocAR/androidGnss; repository licence Apache-2.0'),
    'urbannav-hk-tst-ublox-spp.csv': (
        'u-blox receiver, single-epoch least-squares fixes; slow car, Tsim Sha '
        'Tsui, Hong Kong (dense urban canyon)',
        'UrbanNav-HK-Data20190428 by the Intelligent Positioning and Navigation '
        'Laboratory, The Hong Kong Polytechnic University, via '
        'weisongwen/GraphGNSSLib; data CC BY-NC-SA 4.0, code GPLv3. Not shipped in '
        'this repository (its licence is non-commercial and share-alike), so these '
        'figures cannot be measured again from a clone'),
    'gmt-static-phone-2016-08-22.csv': (
        'Android phone (GnssLogger 1.4) location output; static, open area, '
        'Mountain View',
        'google/gps-measurement-tools (by Google), Apache-2.0'),
}
