"""The demos: they only order calls to the library (``vectorid demo``).

* :mod:`.g12` — the two-step identification of a G-12 parachute (seed 001 §VI) on embedded
  data, and the analytic Binh–Korn demo;
* :mod:`.parafoil` — seed 000 end to end: the 8-DoF parafoil's 33 gains, the reduction, and
  the 6-DoF model beside the 8-DoF one.
"""
