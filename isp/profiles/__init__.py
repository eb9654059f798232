"""Camera profiles: DNG camera profiles read, written and applied (:mod:`isp.profiles.dcp`), fitted to
a camera's spectral sensitivities (:mod:`isp.profiles.fitting`) or to a photographed chart
(:mod:`isp.profiles.chart`); ICC input profiles (:mod:`isp.profiles.icc`), 3-D LUTs
(:mod:`isp.profiles.lut`), the default tone curve (:mod:`isp.profiles.tone`), camera model aliases
(:mod:`isp.profiles.models`), and a check against RawTherapee (:mod:`isp.profiles.rawtherapee`)."""
