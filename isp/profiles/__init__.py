"""DNG camera profiles: read, write and apply (:mod:`isp.profiles.dcp`), fit to a camera's spectral
sensitivities (:mod:`isp.profiles.fitting`), and check against RawTherapee
(:mod:`isp.profiles.rawtherapee`)."""
