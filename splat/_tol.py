"""The numerical thresholds of ``splat``, each with the reason for its value (as ``zonotope/_tol.py``).

``splat`` uses only public ``zonotope`` names, so its own decisions live here. Scene-design constants
of the simulator (cell border widths, the white card's reflectance), optimiser hyper-parameters
(Adam's ε) and defaults of public parameters (``rawnerf_loss(offset=1e-3)``,
``choose_delta(floor=1e-3)``) are documented where they are used, not here.
"""

from __future__ import annotations

__all__ = [
    "ANCHOR_EPS",
    "CARD_DELTA_E_FLOOR",
    "FEASIBLE_DISTANCE",
    "GRID_NM",
    "GUIDE_RADIUS",
    "GUIDE_RANGE",
    "GUIDE_RELIABILITY",
    "JOINT_FIT_RIDGE",
    "JOINT_NSIGMA",
    "OWN_NOISE_FLOOR",
    "PURE_WEIGHT",
    "QUATERNION_NORM_MAX",
    "QUATERNION_NORM_MIN",
    "RAY_SURFACE",
    "RAY_T_MIN",
    "REGION_MIN_PIXELS",
    "REGION_RTOL",
    "RENDER_ERROR_FLOOR",
    "RENDER_ERROR_WINDOW",
    "ROTATION_ATOL",
    "SMOOTH_RTOL",
    "SO3_TAYLOR_THETA2",
    "TEXTURE_NSIGMA",
    "TEXTURE_RTOL",
    "TRACK_VISIBLE_ATOL",
    "TRACK_VISIBLE_RTOL",
    "UNCERTAINTY_PNG_MAX",
    "WARP_RADIUS_MIN",
]

#: A rendered response counts as outside the object-colour solid (``choose_delta``'s "outside"
#: share) when its L∞ distance exceeds this, in white = 1 units: the LP distance of a feasible
#: response is 0 up to HiGHS's feasibility tolerance (~1e-9), so only real infeasibility counts.
FEASIBLE_DISTANCE = 1e-9

#: Wavelength comparisons (nm) between a reflectance set's range and the common grid: grids are
#: built by ``np.arange`` on nm values, whose rounding is ~1e-13 nm; 1e-9 nm accepts that and no
#: real gap.
GRID_NM = 1e-9

#: A supersampled pixel is "pure" (one surface only) when its first sample weight exceeds this: the
#: simulator's weights are 1 up to the float32 sums of 2×2 samples (~1e-7); 0.999 rejects any pixel
#: with a visible second surface.
PURE_WEIGHT = 0.999

#: A COLMAP ``qvec`` is a rotation only if its norm lies in this range: COLMAP writes unit quaternions
#: with 17 digits; a norm near 0 (a zeroed pose) or huge (corrupt binary data) has no rotation.
QUATERNION_NORM_MIN = 1e-6
#: See :data:`QUATERNION_NORM_MIN`.
QUATERNION_NORM_MAX = 1e6

#: Ray casting in the simulator: a ray hits a cylinder's cap when it is within this fraction of the
#: height/radius of the cap's plane and rim (float64 intersections of a 5 m scene are good to
#: ~1e-15 relative; 1e-7 absorbs the float32 scene parameters).
RAY_SURFACE = 1e-7

#: Smallest ray parameter counted as a hit (m): excludes the camera's own origin and self-hits from
#: rounding (~1e-15 m), far below any real distance in the scene.
RAY_T_MIN = 1e-9

#: ``transforms.json`` rotations are accepted when ``RᵀR = I`` to this (absolute): nerfstudio and
#: instant-ngp write 6–8 significant digits, so products carry ~1e-6 errors; 1e-3 still refuses
#: scaled, sheared or zeroed matrices.
ROTATION_ATOL = 1e-3

#: ``so3_exp`` takes ``sin θ / θ`` and ``(1 − cos θ) / θ²`` from their Taylor series (to θ⁴) when
#: ``θ² < this`` (rad²): the first omitted terms are θ⁶/5040 and θ⁶/40320 < 2e-16, so the series is
#: exact to float64 rounding there, while the closed forms lose ~ε/θ² to cancellation (1e-12 at the
#: switch), and neither branch divides by 0 at ω = 0.
SO3_TAYLOR_THETA2 = 1e-4

#: The floor's radial warp ``r → a·log(1 + r/a)/r`` uses its limit 1 below this radius (m): the
#: quotient is exact to rounding from 1e-12 m, and the scene's finest detail is ~1 mm.
WARP_RADIUS_MIN = 1e-12

#: Added to both sums of :func:`splat.fusion.anchor`'s ratio (white = 1 units): keeps the ratio
#: finite where the own channels are black in the render or the photograph (the chart's black patch is
#: ≈ 0.03), and ≪ any lit surface's sum of three channels (≥ 0.05 on the simulated capture).
ANCHOR_EPS = 1e-3

#: Opacity of the splat's render at full resolution above which a textured pixel of the full-size
#: output is that render anchored to its own sites (:func:`splat.strips.full_resolution_view`); below
#: it the render holds too little of the surface for its colour to be the pixel's.
RENDER_ANCHOR_ALPHA = 0.05

#: Largest binning at which the full-size output's textured pixels are the render anchored to their
#: sites: the render is as sharp as the working grid, and it beat the photograph demosaiced on the
#: benchmark capture's all pixels (ΔE00) at binning 2 (5.66 against 7.03) and, rendered with the working
#: footprint (:func:`splat.resolution.working_footprint`), at binning 4 (6.06 against 7.31; with the
#: renderer's own dilation, its surfaces open, it had lost there, 7.90 against 7.60). At binning 8 it
#: lost (9.40 against 9.23): its colour is blurred over f pixels at an edge, the photograph's own
#: channels are not.
RENDER_ANCHOR_BINNING = 4

#: Floor of the measured channels' noise σ (white = 1): the forward model's own error (SSFs on the
#: correction's 10 nm grid, the white scale's estimate, 14-bit rounding) when the sensor noise itself
#: is ~0 (a noise-free simulation). Chosen on one training run of the simulated capture (2000 steps;
#: three cameras, anchored renders, flat pixels of the held-out views): with one σ = 0.02 for every
#: rendered channel, 0.002 gave 0.82 ΔE00 and 0.0005 0.92; with per-camera render σ, 0.002 gave 0.94
#: and 0.001 0.99. Other runs were scored with it fixed (docs/benchmarks.md, multi-camera capture).
OWN_NOISE_FLOOR = 2e-3

#: A pixel of a view is *smooth* (:func:`splat.fusion.smooth`) when every channel of the view's render
#: varies over the pixel's 5 × 5 neighbourhood by at most this fraction of the pixel's mean response
#: (at least 0.02, white = 1). The reprojected photographs' σ is estimated at smooth pixels only
#: (``splat.capture.fusion_of``): there a photograph is read away from its own edges, where a fraction of a
#: pixel of misregistration or the demosaicing's blur would stand in for its error. Over all pixels
#: the estimate is 4–10 × larger (CI coarse capture with noise: 0.0093–0.0106 against 0.0019–0.0027)
#: and, as the weight, cost 0.34 → 0.44 ΔE00 on the flat held-out pixels (noise-free, seed 1). The
#: render is smooth and noise-free, so the test needs no truth and is unmoved by sensor noise. The σ
#: hardly depends on the value (noisy capture: 0.0021–0.0026 per camera at 0.03, 0.0019–0.0027 at 0.1,
#: 0.0021–0.0030 at 0.3; noise-free ≤ 0.0002 at all three), but its support does: a splat's render is
#: blotchy, and 0.03 left 30–111 residuals per camera, 0.1 leaves 1 300–3 400.
SMOOTH_RTOL = 0.1

#: A pixel of a photographed view is *textured* (:func:`splat.fusion.textured`) when some channel's
#: measured sites within its 5 × 5 neighbourhood span more than this fraction of their largest value
#: (at least 0.02, white = 1). There the fused responses take the render anchored to the pixel's own
#: site instead of the reprojected photographs and the demosaiced own channels (``fused_view``): a
#: photograph reprojected through a depth misplaced by a fraction of a pixel, or a channel interpolated
#: across a 1–2 px cell border, is wrong by the step itself, far beyond the σ that the estimator gives
#: it, and outvotes the measured site (six channels to three: the dark borders are painted over).
#: Chosen on the benchmark capture's default model (three cameras, Prior, 12 held-out views, every
#: 4th pixel at three Bayer phases; all-pixel | flat-pixel mean ΔE00): 0.1 → 4.21 | 1.82, 0.2 → 4.05 |
#: 1.15, 0.3 → 3.98 | 0.91, **0.5 → 3.92 | 0.72**, 0.8 → 4.30 | 0.68, against 8.08 | 0.68 with the
#: test off (the fused estimate everywhere) and 4.31 | 2.27 with every pixel textured. At 0.5, 71 % of
#: the pixels are textured and 2 % of the flat ones (mostly dark: median Y 0.09 against 0.20 for all
#: flat pixels, where the noise is a larger part of the signal). Checked on the CI fine capture
#: (pixel-scale texture, 1000 steps, stride 2): 11.54 | 1.42 off, 8.88 | 1.43 at 0.5 (8.83 | 1.42 at
#: 0.8, 8.91 | 1.54 at 0.3); CI coarse noise-free 4.45 | 0.339 → 3.27 | 0.339; on a capture simulated
#: afterwards (coarse, noisy, seed 7) 4.48 | 0.677 → 3.55 | 0.688.
TEXTURE_RTOL = 0.5

#: ... and by more than this many σ of the sensor noise (``fused_view`` passes the view's ``own_sigma``,
#: the NoiseProfile's σ at the channel's median signal): a flat patch's 4–12 sites of one channel in
#: the 5 × 5 window span ≈ 2–3.5 σ of noise alone, so 6 σ leaves noise out, while the relative test
#: alone took 2 % of the benchmark's flat pixels (the dark ones) for textured. Same models, all | flat
#: pixels, at TEXTURE_RTOL: benchmark 0 σ 3.92 | 0.723, 4 σ 3.93 | 0.704, **6 σ 3.95 | 0.684**, 8 σ
#: 3.99 | 0.681 (0.681 with the test off); seed-7 capture 3.553 | 0.688, 3.549 | 0.680, 3.545 | 0.677,
#: 3.540 | 0.677; CI fine 8.879 | 1.429, 8.876 | 1.416, 8.871 | 1.416, 8.864 | 1.416. At 6 σ no more
#: than 0.2 % of the flat pixels are textured on any of the three.
TEXTURE_NSIGMA = 6.0

#: Another camera's reprojected channels are rejected at a pixel (``splat.capture.fused_view``) when no
#: surface gives them together with the view's own channels: the pair lies farther from the two
#: cameras' joint object-colour solid than this many σ, summed over the six channels (L1, as
#: :func:`zonotope.solid_distance` measures; the own channels' sensor σ and the camera's
#: ``reprojected_sigma``). Such a pair is a reprojection misplaced onto another surface (a sliver of a
#: chart patch reading its neighbour through a slightly wrong depth), not noise. Benchmark capture
#: (3000 steps, 12 held-out views, stride 2; three cameras with Prior; region means, chart / uniform,
#: ΔE00, pooled over the regions): none 0.337 / 0.436, 1.5 σ 0.304 / 0.432, **3 σ 0.304 / 0.432**, 6 σ
#: 0.304 / 0.433; the Canon's chart patches 0.408 → 0.308 (one sliver of a black patch, whose other
#: channels read its orange neighbour, had cost 0.12 of that). 0–0.2 % of a view's reprojected pixels
#: are rejected.
JOINT_NSIGMA = 3.0

#: The own camera's other photographs are averaged into its measured channels where they agree with the
#: measurement within JOINT_NSIGMA times the sum of the two σ plus this fraction of the measurement, in
#: every channel: the σ are the sensor's at the median level, and a brighter surface's noise exceeds them
#: (a misplaced reprojection, a neighbour read across an edge, is off by far more). Benchmark capture,
#: binning 1, Prior, chart / uniform region means: one camera (b), the Sigma's views, 0 → 1.817 /
#: 2.372, **0.05 → 1.460 / 2.246**, 0.1 → 1.502 / 2.236, no test 1.477 / 2.234; three cameras 0 →
#: 0.294 / 0.386, **0.05 → 0.292 / 0.386**, no test 0.337 / 0.388 (a 4-pixel black patch read its
#: neighbour, 18.96 ΔE00).
OWN_AGREE_RTOL = 0.05

#: Ridge weight (relative to the mean diagonal) of the smooth reflectance that
#: :func:`splat.fusion.impossible` fits to a pair before its LP: the pair is then settled without the
#: LP when that reflectance's responses lie within the tolerance. It changes which pairs need the LP,
#: never a decision. One benchmark view's two tests (137,207 and 136,063 pairs) left to the LP: plain
#: least squares 49 % / 33 %; ridge 10⁻⁴ 24 %, **10⁻³ 19 %**, 10⁻² 20 % (6 cosines; 8 or 12 no better).
JOINT_FIT_RIDGE = 1e-3

#: The joint bilateral filter that re-reads reprojected photographs guided by the view's own photograph
#: (:func:`splat.fusion.guided`): window radius (px), range σ (relative to the guide's level) and
#: reliability scale (the reprojection's relative 3 × 3 range). Chosen on one model (CI coarse capture,
#: noise-free, 1000 steps, seed 0; three cameras with Prior, held-out views, stride 2) among
#: (2, 0.05, 0 = no reliability term), (2, 0.05, 0.1), (3, 0.03, 0.1), (2, 0.1, 0.1), (1, 0.05, 0.1),
#: (3, 0.02, 0.03), (3, 0.05, 0.03), (3, 0.05, 0.01), (4, 0.03, 0.02): flat pixels 0.320 → 0.285–0.362,
#: all pixels 5.74 → 5.08–5.50; (2, 0.1, 0.1) had the lowest all-pixel error (5.08; flat 0.300). The
#: docs/benchmarks.md (multi-camera capture) has the checks on other models and scenes.
GUIDE_RADIUS = 2
#: See :data:`GUIDE_RADIUS`.
GUIDE_RANGE = 0.1
#: See :data:`GUIDE_RADIUS`.
GUIDE_RELIABILITY = 0.1

#: A simulated COLMAP point is in a training view's track when the view's ray towards it first hits a
#: surface within this of the point's distance (relative, plus :data:`TRACK_VISIBLE_ATOL` in m): the
#: point is itself a float64 ray hit, so an unoccluded ray meets it again to ~1e-12 relative; an
#: occluder closer to the point than 1e-4 of its distance (0.5 mm at 5 m, far below a pixel's footprint
#: there) could not hide it in any image.
TRACK_VISIBLE_RTOL = 1e-4
#: See :data:`TRACK_VISIBLE_RTOL` (m; for points next to a camera, far below any occluder's distance).
TRACK_VISIBLE_ATOL = 1e-6

#: The report states the corrected image's ΔE00 on the marked card as a ratio to the camera
#: development's only when the latter is at least this: 0.05 ΔE00 is far below a visible difference,
#: and a ratio to ~0 says nothing.
CARD_DELTA_E_FLOOR = 0.05

# --- working resolution and full-resolution outputs (splat.resolution, splat.strips) ---------------

#: The automatic working resolution of the train and render steps: each photograph is binned
#: (:func:`splat.resolution.working_factor`) until it holds at most this many pixels. 2¹⁸ = 262 144 px
#: is 3.4 × the 320 × 240 views of the benchmark capture (the largest trained so far: 3000 steps of the
#: CPU rasteriser take minutes there, and time grows with pixels × views), 600 × 400 for a 24 MP
#: 6000 × 4000 photograph (binned 10 × 10); a 4096-Gaussian splat holds far less detail than that, and
#: every output is made at full resolution from the photographs themselves (:mod:`splat.strips`).
TRAIN_PIXEL_BUDGET = 2**18

#: Full-resolution rows read per strip when binning a RAW mosaic (memory only: ~70 MB of float64 per
#: strip of a 6000-px-wide image; the binned result does not depend on it).
BIN_ROWS = 512

#: Full-resolution rows per strip of :mod:`splat.strips` (memory only: the strip's responses, noise
#: codes and correction at 6000 px wide are ~100–200 MB; tests check that the result is the same at
#: any strip height).
STRIP_ROWS = 128

#: Pixels corrected per call of the regression within a strip (memory only: a root-polynomial of nine
#: channels has 45 terms, 2¹⁷ pixels × 45 × 8 B = 47 MB).
CORRECT_CHUNK = 2**17
#: The ΔE00 at which the uncertainty map's PNG (``splat.capture.correct``) turns fully yellow: one scale for
#: every view, so that two maps compare by eye. 10 ΔE00 is a plainly different colour; the fused
#: corrections' flat pixels on the benchmark capture have radii of 1–2, textured and render-only
#: pixels 8 and more (docs/notes/2026-11-30-uncertainty-map.md).
UNCERTAINTY_PNG_MAX = 10.0
#: Window (px, odd) over which the uncertainty map measures the render's local error against the
#: photograph's own sites (``splat.fusion.render_error``): the 5 × 5 of the texture test, so that a
#: textured pixel's window holds the edge that made it textured. With it the map's coverage went from
#: 0.881 to 0.977 on the benchmark capture and from 0.786 to 0.936 at CI size, claim 0.95
#: (docs/notes/2026-11-30-uncertainty-map.md).
RENDER_ERROR_WINDOW = 5
#: Sites whose measured or rendered level (white → 1) is at most this are left out of the render's local
#: error: their ratio is the sensor's noise, not the render's shape (a measured 10⁻³ is ~1 % of a
#: 10 %-grey's level, a few σ of the simulated sensors' read noise).
RENDER_ERROR_FLOOR = 1e-3
# --- region means in scoring (splat.scoring.region_labels) ---

#: A region of the true image is uniform where its XYZ varies by at most 1 % (relative, floor 0.02 in Y)
#: over every 3 × 3 neighbourhood, and a region shows a chart patch when its mean XYZ is within 1 % of
#: the patch's: the simulator's chart sits on the unshaded floor (exactly the patch's XYZ; the truth's
#: float32 rounding is 1e-7), and the closest two ColorChecker N Ohta patches' XYZ differ by 16 % in
#: their most different channel.
REGION_RTOL = 0.01

#: Regions smaller than this many pixels (at full resolution) are left out of the region means: a mean
#: over fewer pixels averages little noise (σ/2 at four), and on the stride grid of the splat scores a
#: smaller region often keeps no pixel at all.
REGION_MIN_PIXELS = 4
# --- the Mitsuba 3 capture (splat.sim.mitsuba) ---

#: Two flat patches' film channels (16 spp, 12 × 28 pixels each, Mitsuba's Monte Carlo over wavelength)
#: must reproduce the ratio of the spectral integrals ∫S R E to 2 %: the wavelength noise of the mean is
#: about 0.5 %, the 5 nm tables against the SSF table's own grid about 0.5 % (1.0 % seen in red).
MITSUBA_PATCH_RTOL = 0.02

#: The chart body lies 1 mm above the floor and its patches and the white card 2 mm: flat shapes on one
#: plane would fight for the same hits (float32 ray tracing), and 1 mm is 0.1 px at the CI size.
MITSUBA_DECAL_LIFT = 1e-3

#: The white card is named in capture.toml only from a view where its brightest raw channel stays below
#: 90 % of the range: Monte Carlo noise and shot noise then keep it clear of clipping.
MITSUBA_WHITE_PEAK = 0.9

# --- the scene light of illuminant = "estimate" (splat.capture.illuminant) ---

#: Rendered pixels sampled for the light's likelihood: the estimate rests on the spread of surfaces,
#: and a few thousand pixels cover a scene's surfaces many times while the 43 candidates' likelihoods
#: stay under a second.
LIGHT_PIXELS = 4000

#: Pixels darker than this fraction of the 99th percentile of brightness are left out of the estimate:
#: there the render's noise, not the surface, sets the chromaticity.
LIGHT_DARK = 0.02

#: The brightest per cent of pixels left out of the estimate: highlights and clipped sites carry the
#: light's colour mixed with the sensor's limits.
LIGHT_SPECULAR = 0.5

#: Bootstrap resamples for the angular uncertainty of the estimated light: its RMS angle is read to a
#: tenth of a degree, not more finely.
LIGHT_BOOTSTRAP = 30
# --- full-resolution reprojection (splat.strips, splat.reproject.reproject_rows) ---

#: Source rows read per band when a strip is reprojected from a full-resolution photograph (memory
#: only, the values do not depend on it): 512 rows of a 24 MP photograph demosaiced are 35 MB in float32.
SOURCE_BAND_ROWS = 512

#: Rows of a source photograph its reader keeps demosaiced for the next strips (memory only, the values
#: do not depend on it; more when one strip needs more): a 128-row strip of a view lands on ~130 rows of
#: a similar view, and on several hundred of a view rolled by a few degrees, so 1024 rows (70 MB of
#: float32 at 24 MP) let the strips of a view read each source row once.
SOURCE_CACHE_ROWS = 1024

#: The blocks (rows, aligned to multiples of it) in which that reader demosaics and keeps a source: each
#: read adds a margin of 2 × :data:`splat.strips.HALO` rows, 12 % of a block of 128.
SOURCE_BLOCK_ROWS = 128

#: Photographs of each other camera read at full resolution per corrected photograph, those that see
#: most of it (at the working resolution): each holds its file's samples (2 bytes a pixel, 48 MB at
#: 24 MP) while the photograph is corrected; the working fusion averages all of them.
FULL_SOURCES = 2

#: Other photographs of the corrected photograph's own camera read at full resolution, averaged into its
#: own channels with the measurement (inverse variance) where they see a plain pixel: the noise the
#: working fusion averages away, kept from the full-size output otherwise.
FULL_OWN_SOURCES = 2
# --- camera levels and clipped photographs (splat.fusion.camera_levels, splat.fusion.unclipped) ---

#: Pixels a view must share with another camera's reprojected photographs for their ratio to count
#: toward the cameras' relative levels: at the path-traced capture's noise (σ ≈ 0.003 of a mean level
#: ≈ 0.1 per pixel) 200 pixels put a ratio within 0.3 % (1 σ), ten times finer than the 3–5 % errors it
#: corrects.
CAMERA_LEVEL_MIN_PIXELS = 200

#: The report names a camera's white per channel as corrected against the other cameras when its
#: levels' largest channel ratio exceeds this: the levels of exact curves agree within 1–3 % per channel
#: (docs/notes/2026-12-01-published-curves.md), published curves' whites differ by 5–25 %.
REPORT_WHITE_TINT = 1.03

# --- a real-size capture: sources per rendered view, decoding once (splat.capture.render, .raw) ---

#: Photographs of each camera reprojected into a rendered view (PipelineConfig.render_sources): those
#: that see most of it. Of 2, 4 and 6, the fewest whose held-out ΔE00 on the CI capture is within 0.05
#: of all of them on flat pixels and on uniform surfaces (4: +0.08 on uniform surfaces; see
#: docs/notes/2026-11-29-realsize-scaling.md); it makes the render step linear in the photographs. On
#: the benchmark capture (16 per camera) all of them lose to 6 on uniform surfaces, 0.81 against 0.44
#: ΔE00 (docs/notes/2026-11-30-region-mean-ladder.md).
RENDER_SOURCES = 6

#: Pixel stride at which a view's pixels are counted to rank the photographs that see it: a ranking by
#: the share seen needs a few thousand pixels, not all of them (1/16 of a view's pixels).
RENDER_SOURCE_STRIDE = 4

# --- full-resolution stage on threads (splat.strips.full_resolution_view workers) ---

#: Most strips the full-resolution stage computes at once by default (fewer where the process may use
#: fewer cores): each adds one strip's work to the peak memory (~0.2 GB at 24 MP), and the stage's
#: share that holds Python's lock bounds the gain beyond a few threads.
FULL_WORKERS = 4

# --- one ranking of source photographs (splat.capture.nearest_sources in the correct step) ---

#: Pixel stride at which the correct step counts a view's pixels to choose the FULL_SOURCES photographs
#: per camera that it reads at full resolution: every pixel. With two sources a near tie decides, and
#: the render step's stride (4) changed 5 of 48 choices on the CI capture (up to 2 % less of the view
#: seen) for a ranking that costs little beside one full-resolution read.
FULL_SOURCE_STRIDE = 1

# --- the full-resolution stage's float32 responses (splat.strips.upsample_rows) ---

#: Relative XYZ difference allowed between the full-resolution stage on float32 responses and on float64
#: ones (the root-polynomial regression with its float32 matrix and the white-point offset): float32
#: rounding of responses that carry ≥ 1e-3 noise, amplified by the regression's cancelling terms; 1e-4
#: moves L* by ≤ 0.004 at the white and is 10× below the noise (measured: ≤ 3.8e-5, ΔE00 ≤ 1.8e-4).
FULL_FLOAT32_RTOL = 1e-4

# --- the converged truth of the Mitsuba capture (splat.sim.mitsuba.truth_xyz) ---

#: A separately rendered truth is the mean of this many independent renders, so that its standard error
#: per pixel comes from their spread (8 chunks: the error of that estimate is about 27 %).
MITSUBA_TRUTH_CHUNKS = 8

#: Two truths of one view rendered with different seeds: the median of |difference| / √(se₁² + se₂²)
#: must lie here. A normal's is 0.67; a standard error estimated from 4 renders (3 degrees of freedom
#: each) makes it a t's, a little larger; equal seeds give 0 and an error not divided by √chunks 0.34.
MITSUBA_TRUTH_Z_MEDIAN = (0.5, 0.95)

# --- the initial points of a model without any (splat.capture.train._seen_region) ---

#: A camera whose distance along its axis to the point nearest every optical axis is below this
#: fraction of the camera centres' spread has no usable focus (parallel or diverging axes); its depths
#: are then scaled by the spread itself.
SEEN_REGION_MIN_DEPTH = 1e-3
