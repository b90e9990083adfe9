"""Multi-flip jumps from a single flip (Majkowska & Faloutsos, "Flipping with physics", SCA 2007;
Majkowska's dissertation, UCLA 2007, sections 5.2-5.4 and appendices B-C).

Pre-processing (once per clip, :func:`prepare`): ballistic phase detection
(:mod:`.phases`), mass distribution from the flight (:mod:`.mass`, eq. 5.1-5.2),
momentum (eq. 5.4-5.5), the self-looping search (:mod:`.looping`, eq. 5.9).
Run time (:func:`multiflip`): sequencing (:mod:`.sequence`, eq. 5.10-5.11),
seam smoothing (:mod:`.smoothing`, eq. 5.14), retiming (:mod:`.retime`, App. B),
repositioning (:mod:`.reposition`, eq. 5.15-5.17).
"""
