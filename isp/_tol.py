"""The numerical thresholds of ``isp``, each with the reason for its value (as ``zonotope/_tol.py``).

``isp`` uses only public ``zonotope`` names, so its own decisions live here rather than in
``zonotope._tol``; thresholds the two packages share come from ``zonotope`` itself (the accepted
reflectance range is :data:`zonotope.REFLECTANCE_MIN` / :data:`zonotope.REFLECTANCE_MAX`).
Defaults of public parameters (``camera_neutral_to_xy(atol=1e-10)``, ``MetamerConfig.quantum``,
``ProfileConfig.smoothness``, ``tonemap_Reinhard2002(log_offset=1e-6)``) are documented where they
are parameters, not here.
"""

from __future__ import annotations

__all__ = [
    "AUTO_BRIGHT_BINS",
    "AUTO_BRIGHT_FRACTION",
    "CHART_BOX",
    "CHART_CLIP_FRACTION",
    "CHART_CLIP_LEVEL",
    "CHART_MIN_SIGNAL",
    "EXPOSURE_NOMINAL",
    "EXPOSURE_RECIPROCAL",
    "LUT_OUTSIDE_QUANTUM",
    "LUT_QUANTUM",
    "NEUTRAL_MIN",
    "NEUTRAL_MISMATCH",
    "NEUTRAL_XY_STEP",
    "STRIPPED_BITS_PER_PIXEL",
    "STRIPPED_NONZERO",
    "TABLE_GREY_SATURATION",
    "TABLE_HARD_WEIGHT",
    "TABLE_RIDGE",
    "TABLE_RING_ROUNDING",
    "WHITE_XY",
]

#: Smallest channel of an as-shot neutral relative to its largest: the white-balance gain is the
#: inverse, and 1/NEUTRAL_MIN = 1000 (10 stops) is far past any light (tungsten needs ≈ 2–4 on blue);
#: smaller values are damaged metadata that would develop a colourless or clipped image.
NEUTRAL_MIN = 1e-3

#: ``isp develop --correction metamer`` warns when the file's AsShotNeutral and the camera's white
#: under ``--illuminant`` (both green-normalised) differ by more than this in some channel. Measured
#: on the three built-in cameras against D65: D55 and D75 differ by 4–10 %, D50 by 7–16 %, FL2 by
#: 13–36 %, A by 29–82 %. So 0.1 stays quiet for daylight near the fit's illuminant and warns for
#: tungsten and fluorescent light (or sensitivities of another camera).
NEUTRAL_MISMATCH = 0.1

#: :func:`isp.profiles.dcp.white_xy` fallback iteration (camera neutral → white xy): stop when the xy estimate
#: moves by less than this (sum of |Δx| + |Δy|). The DNG SDK's own threshold
#: (``dng_color_spec::NeutralToXY``), so that profiles on which the fixed point oscillates give the
#: SDK's answer.
NEUTRAL_XY_STEP = 1e-7

#: :func:`isp.write_dng`: an exposure time ``t < 1`` s is written as the rational ``1/n`` when
#: ``1/t`` is within this of an integer. ``1/n`` computed in float64 and inverted again is off by
#: ≈ 1e-13 relative; times that are not ``1/n`` (1/3.2 s, 0.3 s) are ≥ 1e-3 off, so both sides are
#: far from the threshold.
EXPOSURE_RECIPROCAL = 1e-9

#: EXIF ExposureTime of output images (:func:`isp.output_tags`): a time within 1 % of ``1/n`` is
#: written as ``1/n`` (the camera's nominal speed: 1/200 s rather than 0.004998 s); others in µs.
#: Nominal shutter speeds are ≥ 1/3 stop (≈ 26 %) apart, so 1 % never picks the wrong one.
EXPOSURE_NOMINAL = 0.01

#: :func:`isp.read_raw`: a file smaller than this many bits per mosaic pixel has no pixel data
#: (metadata only, or truncated). Lossless RAW codecs store 12–14-bit data in ≈ 6–10 bits per
#: pixel and lossy ones (lossy DNG, C-RAW) in ≳ 2; no codec stores less than 0.5 bit per pixel.
STRIPPED_BITS_PER_PIXEL = 0.5

#: :func:`isp.read_raw`: a mosaic with fewer non-zero pixels than this fraction is stripped pixel
#: data (LibRaw decodes a file without pixels to zeros). A real frame, even with the lens cap on,
#: has black level and read noise in nearly every pixel; 0.1 % leaves room for a few hundred
#: thousand dead pixels or a masked border on any sensor.
STRIPPED_NONZERO = 1e-3

#: :func:`isp.fit_hue_sat_map`: colours with an SDK-HSV saturation at or below this are left out of
#: a table fit. Their hue is decided by rounding (the hue of grey is undefined) and their hue and
#: saturation rows, weighted by the saturation, would carry nothing; a 10⁻⁴ relative channel
#: difference is far below any correction a table makes (the grey nodes are held at identity).
TABLE_GREY_SATURATION = 1e-4

#: :func:`isp.fit_hue_sat_map`: ring ``j`` of ``S`` is held bias-free when ``j / (S − 1) ≤
#: unbiased_saturation + TABLE_RING_ROUNDING``, so that a ring position given as a float (1/3 for
#: ``S = 4``, 10/29 typed out) includes its ring despite rounding; ring positions are ≥ 1/(S − 1)
#: ≥ 1e-3 apart, so no other ring is ever included.
TABLE_RING_ROUNDING = 1e-12

#: :func:`isp.fit_hue_sat_map`: a ridge of this × the mean squared row weight pulls every table
#: entry towards identity, so the normal equations stay non-singular for nodes no colour reaches
#: (empty hue sectors of a LookTable, ``smoothness = 0``). It moves the entries colours do reach by
#: ≈ 1e-6 relative, far below the table's float32 storage (≈ 6e-8 relative) times the data's
#: condition — and the identity is the right answer where there are no data.
TABLE_RIDGE = 1e-6

#: :func:`isp.fit_hue_sat_map`: the grey nodes (held at identity) and the bias-free ring rows are
#: equality constraints, imposed as least-squares rows weighted 10³ × the mean squared data
#: weight (× the number of colours for the ring rows, which average over every colour's pull).
#: They then hold to ≈ 10⁻³ of the data's pull on those nodes, which is below the fit's noise;
#: a much larger weight only worsens the conditioning of the sparse solve.
TABLE_HARD_WEIGHT = 1e3

#: :func:`isp.XYZ_to_linear_sRGB`: a white chromaticity within this (per coordinate) of sRGB's
#: D65 white is taken as D65 and no chromatic adaptation is applied. White points are tabulated to
#: 4–5 decimals (0.3127, 0.3290), so distinct whites differ by ≥ 1e-5; an adaptation between whites
#: 1e-6 apart would be the identity to ≈ 1e-6 anyway.
WHITE_XY = 1e-6

# --- memory at real sizes (strip-wise development) ---------------------------------------------
#: :meth:`isp.Pipeline.__call__` with ``keep=False`` runs runs of local stages on strips of rows of
#: about this many pixels (2²⁰ ≈ 1 MP): a stage's float64 temporaries (a demosaicing kernel holds
#: ≈ 10 planes) then take tens of MB instead of GB at 60 MP, and a strip is still large enough that
#: numpy's per-call overhead stays below 1 % of the work.
STRIP_PIXELS = 2**20

#: Same: the chunk, in pixels, in which :func:`isp.tonemap_Reinhard2002` and :func:`isp.to_uint16`
#: work through a whole image (their float64 temporaries stay ≈ 50 MB whatever the image size).
CHUNK_PIXELS = 2**20

# --- hardening: absurd options --------------------------------------------------------------------
#: :func:`isp.tonemap_clip` / ``isp develop --exposure``: a gain of at most this many stops either
#: way. 2³² ≈ 4·10⁹ is far beyond any sensor's dynamic range (≤ 2²⁰) and 2**1e6 overflows a float.
EXPOSURE_STOPS_MAX = 32.0

# --- white balance of files that record none ------------------------------------------------------
#: :func:`isp.raw.auto_white_balance`: an 8 × 8 block with a raw value above ``white − black −`` this is
#: left out of the grey-world average (it holds clipped pixels, whose colour is the clip's, not the
#: scene's); 25 raw units is LibRaw's (dcraw's ``maximum − 25``), so the two choose the same white.
AUTO_WB_MARGIN = 25

# --- camera profiles: charts, ICC and LUT (isp.profiles.chart, isp.profiles.icc, isp.profiles.lut) ---

#: :func:`isp.profiles.chart.read_chart`: half side of a patch's measuring box as a fraction of the
#: patch pitch. A ColorChecker patch covers ≈ 0.85 of its pitch, so a box of 0.5 pitch stays inside
#: the patch with 0.17 pitch to spare on each side for corners clicked a few pixels off or a slight
#: lens distortion the homography does not model.
CHART_BOX = 0.25

#: :func:`isp.profiles.chart.read_chart`: a raw value at or above this fraction of the white level is
#: clipped. Sensors saturate a little below the nominal white level (the 550D DNG's brightest pixel
#: is 0.81 of it on an unclipped chart; clipped sensels sit within ≈ 1 % of it), so 0.98 catches
#: saturation without taking bright but linear sensels for clipped.
CHART_CLIP_LEVEL = 0.98

#: :func:`isp.profiles.chart.read_chart`: a patch with more than this fraction of clipped sensels is
#: refused. One hot pixel in a 40 × 40 box is 0.06 %; a clipped patch has most of its sensels at
#: the white level, so 1 % separates the two.
CHART_CLIP_FRACTION = 0.01

#: :func:`isp.profiles.chart.read_chart`: the brightest neutral patch must reach this fraction of
#: the raw range. Below it (≈ 7 stops under clipping) a 14-bit sensor's read noise and quantisation
#: are several percent of the dark patches' signal and the fit is noise (the 550D chart's white
#: patch is at 9 %).
CHART_MIN_SIGNAL = 0.01

#: :func:`isp.profiles.lut.profile_LUT`: lattice nodes that need a solver are grouped within this
#: (response units, white = 1), the grouping :class:`isp.MetamerCorrection` uses on photographs.
#: Measured on a 17³ Prior LUT (Nikon 5100, D65) against every node solved: natural colours
#: (ColorChecker, CIE 1995 TCS, NIST CQS) unchanged, 100 atypical spectra ΔE00 0.004 mean / 0.37
#: max; at 33³ 3.7× faster, all unchanged. 5e-3 is 6× faster at 33³ but errs by up to 4–7 ΔE00 on
#: the atypical colours an MMV estimator is chosen for (docs/notes/2026-11-29-profiles.md).
LUT_QUANTUM = 2e-3

# --- reference light (isp develop --correction metamer --reference) ---
#: Chroma C*ab (CIELAB, D65) a spectrally flat grey may keep in a developed 16-bit sRGB image: the
#: correction's white is adapted to D50 and then D65 exactly, leaving 16-bit rounding and the
#: demosaicing of patch interiors (0.01 measured).
REFERENCE_GREY_CHROMA = 0.3

# --- default brightness (isp develop's auto-bright) ---

#: :func:`isp.tonemap_auto_bright`: the share of pixels allowed at or above white, LibRaw's
#: ``auto_bright_thr`` default (0.01), so that isp's default rendering has rawpy's brightness
#: (within 0.3 stop on the 550D DNG and the D30 CRW: docs/notes/2026-11-29-isp-default-brightness.md).
AUTO_BRIGHT_FRACTION = 0.01

#: Bins of the per-channel histogram :func:`isp.auto_bright_white` counts from the top (over 0 to
#: the image's largest value): 2¹⁶, a 16-bit output's steps, finer than dcraw's 2¹³.
AUTO_BRIGHT_BINS = 2**16

# --- LUT sampling outside the object-colour solid (isp profile --lut) ---

#: :func:`isp.profiles.lut.profile_LUT`: lattice nodes none of whose neighbouring cells can meet the
#: object-colour solid (64 % of a 33³ lattice) are grouped within this. No colour of a surface is
#: interpolated from them (tested), so the radius only shapes the LUT past any surface (noise,
#: highlights); 10× the radius of the other nodes (docs/notes/2026-11-29-lut-speed.md).
LUT_OUTSIDE_QUANTUM = 0.02

# --- automatic chart detection (isp profile --chart without --chart-corners) ---
__all__ += [
    "CHART_DETECT_AREA",
    "CHART_DETECT_CELL",
    "CHART_DETECT_LINK",
    "CHART_DETECT_MAX_DE",
    "CHART_DETECT_MIN_SQUARES",
    "CHART_DETECT_PATCH",
    "CHART_DETECT_SHIFT",
    "CHART_DETECT_SIMILAR",
    "CHART_DETECT_WHITE_PERCENTILE",
]

#: :func:`isp.profiles.chart_detect.raw_preview`: the green percentile scaled to 1 before the
#: segmenter (which encodes with sRGB and clips at 1): the brightest 0.5 % of the frame (a lamp, a
#: window) may clip, so that a small highlight does not darken the chart; a chart's white patch is
#: ≈ 1/200 of a frame the chart fills a fifth of. Chosen, not tuned (the 550D DNG is found with 99–100).
CHART_DETECT_WHITE_PERCENTILE = 99.5

#: A segmented square belongs to a grid cell when its centre is within this many patch pitches of
#: the cell's centre along each axis: the ColorChecker's patches are 0.84 pitch wide, so 0.3 keeps
#: squares misplaced by a quarter patch and refuses those on the gaps or the chart's border.
CHART_DETECT_CELL = 0.3

#: Fewest segmented squares a 4 × 6 grid is fitted to (8 homography unknowns, two equations each,
#: and spread over three columns and two rows): 6 of the 24, so that a chart with most patches
#: unfound is refused rather than fitted to a few squares that may be the Passport's other side.
CHART_DETECT_MIN_SQUARES = 6

#: Largest mean ΔE00 of the white-preserving least-squares matrix over the 24 patches for a grid to
#: be taken as the chart. Measured: the 550D DNG's chart 2.5 under A, 2.9 when told D50; the same grid
#: rotated or mirrored 33–42; the reference chart with its 18 colours shuffled (neutral row in place,
#: 200 permutations) 17.8 at least. 10 sits between, with room for a light misnamed by the user.
CHART_DETECT_MAX_DE = 10.0

#: Segmented squares are grouped into one candidate chart when their centres are less than this many
#: sides apart and their sides differ by less than this ratio: a ColorChecker's neighbours are 1.25
#: sides apart (up to ≈ 1.6 under the perspective a chart is photographed in), diagonals 1.8.
CHART_DETECT_LINK = 1.7

#: A ColorChecker Classic patch's side in patch pitches (X-Rite's layout: 40 mm patches on a 47.6 mm
#: pitch, ≈ 0.84): the area the refinement of the patch centres expects a patch's pixels to cover.
CHART_DETECT_PATCH = 0.84

#: Pixels within this relative RGB distance of a patch's middle colour belong to the patch when its
#: centre is refined: neighbouring patches of the chart differ by ≥ 35 % of the brighter one's norm
#: (the neutral row's steps), noise at a few percent stays inside.
CHART_DETECT_SIMILAR = 0.2

#: A patch's pixels (those like its middle colour) are its own when their area is within this
#: fraction of a patch's: more means it merges with a like-coloured surround (the black patch on the
#: chart's black body), less that the window cut it; neither gives a centroid at the patch's centre.
CHART_DETECT_AREA = 0.3

#: Largest move, in patch pitches, of any patch centre by the refinement: the segmented squares'
#: grid is within 0.1 pitch (benchmarks/bench_chart_detect.py), so a larger move is a refit gone wrong
#: and the squares' grid is kept; 0.25 still keeps the sampling box inside the patch.
CHART_DETECT_SHIFT = 0.25
