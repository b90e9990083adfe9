"""The run-time stage's outputs are pinned bit for bit (issue 4's overhead work must not change them).

``REFERENCE`` holds SHA-256 prefixes of every output of :func:`mocomp.flips.multiflip` (the new
motion's root positions and rotations, sequence positions and warped times, seam speeds, the frame
plan, the COM trajectory, the retiming plan, the join, the source info, and the physics report
without its timings), made with the code *before* the overhead reductions of the run-time stage
(commit a0bd955: ``np.take`` gathers, cached per-clip kernel inputs, no defensive copies of
arrays the kernels only read, the sequence filled in place). Synthetic back/front/side flips with
2-4 flips and the option paths (no seam retiming, ``k_ratio=1``, height changes, an extra
rotation that is not whole turns, a window, an explicit ``k``), with and without the report.
Bits depend on numpy's and numba's versions (libm, SIMD paths), so the check runs only on the
versions that made the reference and is skipped, saying why, elsewhere.
"""
import dataclasses
import hashlib

import numba
import numpy as np
import pytest

from mocomp.flips import multiflip, prepare

from _flips_data import synthetic

MADE_WITH = {"numpy": "2.4.6", "numba": "0.68.1"}

REFERENCE = {
    "backflip flips=2": {
        "motionFalse": "599aa48748cf7ebb",
        "auxFalse": "f23bc8f09e2e271b",
        "miscFalse": "((122, 276), 118.0, (0.9748545121657306, 1.392649303093901, 0.7, 9.810002663212916, 1.2585215417491231, 1.2909839632923272, 3.1320923710282225, -0.06388029871845302, 6.282796190522762, 3.229461810106038, -3.1392384455678184, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 6.28 m/s vertically while the retimed take-off reaches 3.05 m/s: the linear momentum jumps at take-off by +104% of the retimed take-off momentum M k|v| (k|v| = 3.11 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.14 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.107754640596814), -4.905001331606458, 1.2909839632923272, LandingJoin(u=103, f=154, copy=3, g=172, distance=2.5777990853015343e-16, delta=-0.03811563049528921, n_pairs=54), (170, 200, 230), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (2) by mocomp.flips from motion: k=0.975')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "599aa48748cf7ebb",
        "auxTrue": "f23bc8f09e2e271b",
        "miscTrue": "((122, 276), 118.0, (0.9748545121657306, 1.392649303093901, 0.7, 9.810002663212916, 1.2585215417491231, 1.2909839632923272, 3.1320923710282225, -0.06388029871845302, 6.282796190522762, 3.229461810106038, -3.1392384455678184, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 6.28 m/s vertically while the retimed take-off reaches 3.05 m/s: the linear momentum jumps at take-off by +104% of the retimed take-off momentum M k|v| (k|v| = 3.11 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.14 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.107754640596814), -4.905001331606458, 1.2909839632923272, LandingJoin(u=103, f=154, copy=3, g=172, distance=2.5777990853015343e-16, delta=-0.03811563049528921, n_pairs=54), (170, 200, 230), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (2) by mocomp.flips from motion: k=0.975')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "e5d9bcf4ed7289a3"
    },
    "backflip flips=3": {
        "motionFalse": "37728a2c60c0149c",
        "auxFalse": "bf36d03170604d03",
        "miscFalse": "((100, 288), 118.0, (1.1903373429614263, 1.7004819185163234, 0.7, 9.810002663212916, 1.8666331191917682, 1.5681547170046715, 3.1320923710282225, -0.06388029871845302, 7.651065008126648, 3.9228184972871594, -3.7732852206810903, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 7.65 m/s vertically while the retimed take-off reaches 3.73 m/s: the linear momentum jumps at take-off by +103% of the retimed take-off momentum M k|v| (k|v| = 3.79 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.77 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.7946958805635167), -4.905001331606458, 1.5681547170046715, LandingJoin(u=175, f=166, copy=5, g=171, distance=3.573530360512223e-17, delta=0.010505817852262567, n_pairs=62), (170, 200, 230, 260, 290), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (3) by mocomp.flips from motion: k=1.190')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "37728a2c60c0149c",
        "auxTrue": "bf36d03170604d03",
        "miscTrue": "((100, 288), 118.0, (1.1903373429614263, 1.7004819185163234, 0.7, 9.810002663212916, 1.8666331191917682, 1.5681547170046715, 3.1320923710282225, -0.06388029871845302, 7.651065008126648, 3.9228184972871594, -3.7732852206810903, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 7.65 m/s vertically while the retimed take-off reaches 3.73 m/s: the linear momentum jumps at take-off by +103% of the retimed take-off momentum M k|v| (k|v| = 3.79 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.77 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.7946958805635167), -4.905001331606458, 1.5681547170046715, LandingJoin(u=175, f=166, copy=5, g=171, distance=3.573530360512223e-17, delta=0.010505817852262567, n_pairs=62), (170, 200, 230, 260, 290), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (3) by mocomp.flips from motion: k=1.190')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "a8cc441f22254f07"
    },
    "backflip flips=4": {
        "motionFalse": "22af6b600685a222",
        "auxFalse": "97e9a2e5ce4753bf",
        "miscFalse": "((87, 303), 118.0, (1.3701655433308526, 1.957379347615504, 0.7, 9.810002663212916, 2.4667293704888205, 1.8003148469872021, 3.1320923710282225, -0.06388029871845302, 8.795063873421688, 4.503578828109385, -4.308640592953985, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 8.80 m/s vertically while the retimed take-off reaches 4.29 m/s: the linear momentum jumps at take-off by +103% of the retimed take-off momentum M k|v| (k|v| = 4.37 m/s; p_jump_takeoff_rel), and the vertical velocity by -4.31 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 4.367973141153606), -4.905001331606458, 1.8003148469872021, LandingJoin(u=247, f=148, copy=8, g=171, distance=4.798245134551849e-16, delta=-0.027609812643024867, n_pairs=61), (170, 200, 230, 260, 290, 320, 350, 380), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (4) by mocomp.flips from motion: k=1.370')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "22af6b600685a222",
        "auxTrue": "97e9a2e5ce4753bf",
        "miscTrue": "((87, 303), 118.0, (1.3701655433308526, 1.957379347615504, 0.7, 9.810002663212916, 2.4667293704888205, 1.8003148469872021, 3.1320923710282225, -0.06388029871845302, 8.795063873421688, 4.503578828109385, -4.308640592953985, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 8.80 m/s vertically while the retimed take-off reaches 4.29 m/s: the linear momentum jumps at take-off by +103% of the retimed take-off momentum M k|v| (k|v| = 4.37 m/s; p_jump_takeoff_rel), and the vertical velocity by -4.31 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 4.367973141153606), -4.905001331606458, 1.8003148469872021, LandingJoin(u=247, f=148, copy=8, g=171, distance=4.798245134551849e-16, delta=-0.027609812643024867, n_pairs=61), (170, 200, 230, 260, 290, 320, 350, 380), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (4) by mocomp.flips from motion: k=1.370')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "defbec8addcddf55"
    },
    "frontflip flips=2": {
        "motionFalse": "a1d97fc83271b1ab",
        "auxFalse": "cfb34373bc85b729",
        "miscFalse": "((127, 275), 117.0, (0.922685551538945, 1.3181222164842072, 0.7, 9.810574514580802, 1.1331189968336404, 1.2280662626002041, 3.214065385174615, 0.016950969114654546, 6.037820765012996, 3.0722490724109246, -3.0919375236861946, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 6.04 m/s vertically while the retimed take-off reaches 2.97 m/s: the linear momentum jumps at take-off by +100% of the retimed take-off momentum M k|v| (k|v| = 3.08 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.09 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.0813191959684523), -4.905287257290401, 1.2280662626002041, LandingJoin(u=86, f=157, copy=3, g=171, distance=3.573530360512223e-17, delta=0.048547590720019684, n_pairs=59), (166, 190, 214), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.frontflip', 'multi-flip (2) by mocomp.flips from motion: k=0.923')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "a1d97fc83271b1ab",
        "auxTrue": "cfb34373bc85b729",
        "miscTrue": "((127, 275), 117.0, (0.922685551538945, 1.3181222164842072, 0.7, 9.810574514580802, 1.1331189968336404, 1.2280662626002041, 3.214065385174615, 0.016950969114654546, 6.037820765012996, 3.0722490724109246, -3.0919375236861946, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 6.04 m/s vertically while the retimed take-off reaches 2.97 m/s: the linear momentum jumps at take-off by +100% of the retimed take-off momentum M k|v| (k|v| = 3.08 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.09 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.0813191959684523), -4.905287257290401, 1.2280662626002041, LandingJoin(u=86, f=157, copy=3, g=171, distance=3.573530360512223e-17, delta=0.048547590720019684, n_pairs=59), (166, 190, 214), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.frontflip', 'multi-flip (2) by mocomp.flips from motion: k=0.923')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "fb93fdc415196f94"
    },
    "frontflip flips=3": {
        "motionFalse": "6b762364d0f56b02",
        "auxFalse": "cde620f005d7de76",
        "miscFalse": "((107, 283), 117.0, (1.098522494216488, 1.5693178488806971, 0.7, 9.810574514580802, 1.6083688660626914, 1.4641201018007803, 3.214065385174615, 0.016950969114654546, 7.193507259535003, 3.6627841360381077, -3.695936310428969, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 7.19 m/s vertically while the retimed take-off reaches 3.53 m/s: the linear momentum jumps at take-off by +100% of the retimed take-off momentum M k|v| (k|v| = 3.67 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.70 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.668528723557818), -4.905287257290401, 1.4641201018007803, LandingJoin(u=142, f=165, copy=5, g=170, distance=2.5777990853015348e-16, delta=-0.012072627144441128, n_pairs=69), (166, 190, 214, 238, 262), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.frontflip', 'multi-flip (3) by mocomp.flips from motion: k=1.099')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "6b762364d0f56b02",
        "auxTrue": "cde620f005d7de76",
        "miscTrue": "((107, 283), 117.0, (1.098522494216488, 1.5693178488806971, 0.7, 9.810574514580802, 1.6083688660626914, 1.4641201018007803, 3.214065385174615, 0.016950969114654546, 7.193507259535003, 3.6627841360381077, -3.695936310428969, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 7.19 m/s vertically while the retimed take-off reaches 3.53 m/s: the linear momentum jumps at take-off by +100% of the retimed take-off momentum M k|v| (k|v| = 3.67 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.70 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.668528723557818), -4.905287257290401, 1.4641201018007803, LandingJoin(u=142, f=165, copy=5, g=170, distance=2.5777990853015348e-16, delta=-0.012072627144441128, n_pairs=69), (166, 190, 214, 238, 262), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.frontflip', 'multi-flip (3) by mocomp.flips from motion: k=1.099')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "dbd9b242de833073"
    },
    "frontflip flips=4": {
        "motionFalse": "eb11ee31856eb067",
        "auxFalse": "4c5d9bc63df032ce",
        "miscFalse": "((94, 294), 117.0, (1.2522440726968855, 1.7889201038526938, 0.7, 9.810574514580802, 2.0915857885702485, 1.6702700648969504, 3.214065385174615, 0.016950969114654546, 8.203303105287182, 4.178508777442038, -4.222398193040499, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 8.20 m/s vertically while the retimed take-off reaches 4.02 m/s: the linear momentum jumps at take-off by +100% of the retimed take-off momentum M k|v| (k|v| = 4.18 m/s; p_jump_takeoff_rel), and the vertical velocity by -4.22 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 4.181883733632697), -4.905287257290401, 1.6702700648969504, LandingJoin(u=197, f=148, copy=8, g=167, distance=2.5777990853015348e-16, delta=0.036474963575578556, n_pairs=60), (166, 190, 214, 238, 262, 286, 310, 334), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.frontflip', 'multi-flip (4) by mocomp.flips from motion: k=1.252')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "eb11ee31856eb067",
        "auxTrue": "4c5d9bc63df032ce",
        "miscTrue": "((94, 294), 117.0, (1.2522440726968855, 1.7889201038526938, 0.7, 9.810574514580802, 2.0915857885702485, 1.6702700648969504, 3.214065385174615, 0.016950969114654546, 8.203303105287182, 4.178508777442038, -4.222398193040499, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 8.20 m/s vertically while the retimed take-off reaches 4.02 m/s: the linear momentum jumps at take-off by +100% of the retimed take-off momentum M k|v| (k|v| = 4.18 m/s; p_jump_takeoff_rel), and the vertical velocity by -4.22 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 4.181883733632697), -4.905287257290401, 1.6702700648969504, LandingJoin(u=197, f=148, copy=8, g=167, distance=2.5777990853015348e-16, delta=0.036474963575578556, n_pairs=60), (166, 190, 214, 238, 262, 286, 310, 334), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.frontflip', 'multi-flip (4) by mocomp.flips from motion: k=1.252')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "739841a9b18e376d"
    },
    "sideflip flips=2": {
        "motionFalse": "f0593ea900cd579a",
        "auxFalse": "d5cbf5d4be003ddc",
        "miscFalse": "((125, 274), 118.0, (0.9455879603123469, 1.3508399433033529, 0.7, 9.810010844441239, 1.168330274844476, 1.235559592423906, 3.1320958761061526, -0.009806431585905218, 6.052489666151069, 3.090817515161139, -3.0777890924052413, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 6.05 m/s vertically while the retimed take-off reaches 2.96 m/s: the linear momentum jumps at take-off by +101% of the retimed take-off momentum M k|v| (k|v| = 3.05 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.08 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.0481165919637756), -4.905005422220619, 1.235559592423906, LandingJoin(u=74, f=147, copy=6, g=150, distance=0.035164775267126275, delta=0.08454669361861633, n_pairs=29), (149, 160, 171, 182, 193, 204), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.sideflip', 'multi-flip (2) by mocomp.flips from motion: k=0.946')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "f0593ea900cd579a",
        "auxTrue": "d5cbf5d4be003ddc",
        "miscTrue": "((125, 274), 118.0, (0.9455879603123469, 1.3508399433033529, 0.7, 9.810010844441239, 1.168330274844476, 1.235559592423906, 3.1320958761061526, -0.009806431585905218, 6.052489666151069, 3.090817515161139, -3.0777890924052413, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 6.05 m/s vertically while the retimed take-off reaches 2.96 m/s: the linear momentum jumps at take-off by +101% of the retimed take-off momentum M k|v| (k|v| = 3.05 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.08 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.0481165919637756), -4.905005422220619, 1.235559592423906, LandingJoin(u=74, f=147, copy=6, g=150, distance=0.035164775267126275, delta=0.08454669361861633, n_pairs=29), (149, 160, 171, 182, 193, 204), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.sideflip', 'multi-flip (2) by mocomp.flips from motion: k=0.946')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "871009721211606e"
    },
    "sideflip flips=3": {
        "motionFalse": "eebd5acf1df8ead8",
        "auxFalse": "b92393372dd927fe",
        "miscFalse": "((104, 282), 118.0, (1.1367959381186108, 1.623994197312301, 0.7000000000000001, 9.810010844441239, 1.6872120670264408, 1.4841819982386326, 3.1320958761061526, -0.009806431585905218, 7.273313451706117, 3.712759581950591, -3.6912277740094885, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 7.27 m/s vertically while the retimed take-off reaches 3.56 m/s: the linear momentum jumps at take-off by +101% of the retimed take-off momentum M k|v| (k|v| = 3.66 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.69 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.664478299313133), -4.905005422220619, 1.4841819982386326, LandingJoin(u=136, f=143, copy=12, g=150, distance=0.0777016068785704, delta=0.06804973341888321, n_pairs=37), (149, 160, 171, 182, 193, 204, 215, 226, 237, 248, 259, 270), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.sideflip', 'multi-flip (3) by mocomp.flips from motion: k=1.137')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "eebd5acf1df8ead8",
        "auxTrue": "b92393372dd927fe",
        "miscTrue": "((104, 282), 118.0, (1.1367959381186108, 1.623994197312301, 0.7000000000000001, 9.810010844441239, 1.6872120670264408, 1.4841819982386326, 3.1320958761061526, -0.009806431585905218, 7.273313451706117, 3.712759581950591, -3.6912277740094885, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 7.27 m/s vertically while the retimed take-off reaches 3.56 m/s: the linear momentum jumps at take-off by +101% of the retimed take-off momentum M k|v| (k|v| = 3.66 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.69 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.664478299313133), -4.905005422220619, 1.4841819982386326, LandingJoin(u=136, f=143, copy=12, g=150, distance=0.0777016068785704, delta=0.06804973341888321, n_pairs=37), (149, 160, 171, 182, 193, 204, 215, 226, 237, 248, 259, 270), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.sideflip', 'multi-flip (3) by mocomp.flips from motion: k=1.137')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "c6d04995ba57cfec"
    },
    "sideflip flips=4": {
        "motionFalse": "a6388396f6e8d495",
        "auxFalse": "043da62bdbf4905b",
        "miscFalse": "((91, 295), 118.0, (1.297721680222224, 1.8538881146031772, 0.7, 9.810010844441239, 2.1977629864342045, 1.6935549586085792, 3.1320958761061526, -0.009806431585905218, 8.301105812907462, 4.236517089949887, -4.20843284286099, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 8.30 m/s vertically while the retimed take-off reaches 4.06 m/s: the linear momentum jumps at take-off by +101% of the retimed take-off momentum M k|v| (k|v| = 4.18 m/s; p_jump_takeoff_rel), and the vertical velocity by -4.21 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 4.183224777872439), -4.905005422220619, 1.6935549586085792, LandingJoin(u=197, f=149, copy=17, g=150, distance=0.012044649105382919, delta=-0.0497244826780161, n_pairs=23), (149, 160, 171, 182, 193, 204, 215, 226, 237, 248, 259, 270, 281, 292, 303, 314, 325), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.sideflip', 'multi-flip (4) by mocomp.flips from motion: k=1.298')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "a6388396f6e8d495",
        "auxTrue": "043da62bdbf4905b",
        "miscTrue": "((91, 295), 118.0, (1.297721680222224, 1.8538881146031772, 0.7, 9.810010844441239, 2.1977629864342045, 1.6935549586085792, 3.1320958761061526, -0.009806431585905218, 8.301105812907462, 4.236517089949887, -4.20843284286099, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 8.30 m/s vertically while the retimed take-off reaches 4.06 m/s: the linear momentum jumps at take-off by +101% of the retimed take-off momentum M k|v| (k|v| = 4.18 m/s; p_jump_takeoff_rel), and the vertical velocity by -4.21 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 4.183224777872439), -4.905005422220619, 1.6935549586085792, LandingJoin(u=197, f=149, copy=17, g=150, distance=0.012044649105382919, delta=-0.0497244826780161, n_pairs=23), (149, 160, 171, 182, 193, 204, 215, 226, 237, 248, 259, 270, 281, 292, 303, 314, 325), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.sideflip', 'multi-flip (4) by mocomp.flips from motion: k=1.298')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "b6f83f0d7c5af459"
    },
    "backflip flips=2,seam_retime=False": {
        "motionFalse": "83d79eae65ab52ac",
        "auxFalse": "9b1ba924055a3ef4",
        "miscFalse": "((122, 276), 118.0, (0.9747804534968201, 1.3925435049954573, 0.7, 9.810002663212916, 1.2583333333333333, 1.2908889676842892, 3.1320923710282225, -0.06388029871845302, 6.282326595603059, 3.2292241737782374, -3.1390224642561098, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 6.28 m/s vertically while the retimed take-off reaches 3.05 m/s: the linear momentum jumps at take-off by +104% of the retimed take-off momentum M k|v| (k|v| = 3.11 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.14 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.1075185477551535), -4.905001331606458, 1.2908889676842892, LandingJoin(u=103, f=154, copy=3, g=172, distance=2.5777990853015343e-16, delta=-0.03811563049528921, n_pairs=54), (170, 200, 230), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (2) by mocomp.flips from motion: k=0.975')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "83d79eae65ab52ac",
        "auxTrue": "9b1ba924055a3ef4",
        "miscTrue": "((122, 276), 118.0, (0.9747804534968201, 1.3925435049954573, 0.7, 9.810002663212916, 1.2583333333333333, 1.2908889676842892, 3.1320923710282225, -0.06388029871845302, 6.282326595603059, 3.2292241737782374, -3.1390224642561098, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 6.28 m/s vertically while the retimed take-off reaches 3.05 m/s: the linear momentum jumps at take-off by +104% of the retimed take-off momentum M k|v| (k|v| = 3.11 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.14 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.1075185477551535), -4.905001331606458, 1.2908889676842892, LandingJoin(u=103, f=154, copy=3, g=172, distance=2.5777990853015343e-16, delta=-0.03811563049528921, n_pairs=54), (170, 200, 230), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (2) by mocomp.flips from motion: k=0.975')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "6936d1386825d7c5"
    },
    "backflip flips=2,k_ratio=1.0": {
        "motionFalse": "7180b14ea6c2686f",
        "auxFalse": "a370de476a82ee28",
        "miscFalse": "((85, 194), 118.0, (1.392649303093901, 1.392649303093901, 1.0, 9.810002663212916, 1.2585215417491231, 0.903688774304629, 3.1320923710282225, -0.06388029871845302, 4.361906257738176, -1.7763568394002505e-15, 0.12889052076888508, '', 4.439649486566878), -4.905001331606458, 0.903688774304629, LandingJoin(u=103, f=154, copy=3, g=172, distance=2.5777990853015343e-16, delta=-0.03811563049528921, n_pairs=54), (170, 200, 230), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (2) by mocomp.flips from motion: k=1.393')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "7180b14ea6c2686f",
        "auxTrue": "a370de476a82ee28",
        "miscTrue": "((85, 194), 118.0, (1.392649303093901, 1.392649303093901, 1.0, 9.810002663212916, 1.2585215417491231, 0.903688774304629, 3.1320923710282225, -0.06388029871845302, 4.361906257738176, -1.7763568394002505e-15, 0.12889052076888508, '', 4.439649486566878), -4.905001331606458, 0.903688774304629, LandingJoin(u=103, f=154, copy=3, g=172, distance=2.5777990853015343e-16, delta=-0.03811563049528921, n_pairs=54), (170, 200, 230), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (2) by mocomp.flips from motion: k=1.393')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "e2bd6f352a46904f"
    },
    "backflip flips=3,height_change=-0.3,takeoff_height_change=0.2": {
        "motionFalse": "32a79b7b73e3dbc8",
        "auxFalse": "d3850befe29a76b6",
        "miscFalse": "((104, 300), 118.0, (1.1429724974250162, 1.632817853464309, 0.7, 9.810002663212916, 1.8666331191917682, 1.6331391379906999, 3.1320923710282225, -0.563880298718453, 7.665275759216902, 4.0853803197369345, -4.554114837901049, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 7.67 m/s vertically while the retimed take-off reaches 3.58 m/s: the linear momentum jumps at take-off by +112% of the retimed take-off momentum M k|v| (k|v| = 3.64 m/s; p_jump_takeoff_rel), and the vertical velocity by -4.55 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.6437007149465312), -4.905001331606458, 1.6331391379906999, LandingJoin(u=175, f=166, copy=5, g=171, distance=3.573530360512223e-17, delta=0.010505817852262567, n_pairs=62), (170, 200, 230, 260, 290), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (3) by mocomp.flips from motion: k=1.143')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "32a79b7b73e3dbc8",
        "auxTrue": "d3850befe29a76b6",
        "miscTrue": "((104, 300), 118.0, (1.1429724974250162, 1.632817853464309, 0.7, 9.810002663212916, 1.8666331191917682, 1.6331391379906999, 3.1320923710282225, -0.563880298718453, 7.665275759216902, 4.0853803197369345, -4.554114837901049, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 7.67 m/s vertically while the retimed take-off reaches 3.58 m/s: the linear momentum jumps at take-off by +112% of the retimed take-off momentum M k|v| (k|v| = 3.64 m/s; p_jump_takeoff_rel), and the vertical velocity by -4.55 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.6437007149465312), -4.905001331606458, 1.6331391379906999, LandingJoin(u=175, f=166, copy=5, g=171, distance=3.573530360512223e-17, delta=0.010505817852262567, n_pairs=62), (170, 200, 230, 260, 290), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (3) by mocomp.flips from motion: k=1.143')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "3efcf1cb5c01e15d"
    },
    "sideflip flips=None,extra_rotation=5.235987755982989": {
        "motionFalse": "0a88a20fad42c366",
        "auxFalse": "5e52e83c77f2220a",
        "miscFalse": "((130, 273), 118.0, (0.9110034215923036, 1.3014334594175767, 0.7, 9.810010844441239, 1.0846542318274828, 1.1906148825782261, 3.1320958761061526, -0.009806431585905218, 5.83173601184746, 2.9783859519596114, -2.9670138303854605, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 5.83 m/s vertically while the retimed take-off reaches 2.85 m/s: the linear momentum jumps at take-off by +101% of the retimed take-off momentum M k|v| (k|v| = 2.94 m/s; p_jump_takeoff_rel), and the vertical velocity by -2.97 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 2.936632826600312), -4.905005422220619, 1.1906148825782261, LandingJoin(u=63, f=147, copy=5, g=150, distance=0.035164775267126275, delta=0.019927253553753133, n_pairs=29), (149, 160, 171, 182, 193), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.sideflip', 'multi-flip (extra rotation) by mocomp.flips from motion: k=0.911')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "0a88a20fad42c366",
        "auxTrue": "5e52e83c77f2220a",
        "miscTrue": "((130, 273), 118.0, (0.9110034215923036, 1.3014334594175767, 0.7, 9.810010844441239, 1.0846542318274828, 1.1906148825782261, 3.1320958761061526, -0.009806431585905218, 5.83173601184746, 2.9783859519596114, -2.9670138303854605, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 5.83 m/s vertically while the retimed take-off reaches 2.85 m/s: the linear momentum jumps at take-off by +101% of the retimed take-off momentum M k|v| (k|v| = 2.94 m/s; p_jump_takeoff_rel), and the vertical velocity by -2.97 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 2.936632826600312), -4.905005422220619, 1.1906148825782261, LandingJoin(u=63, f=147, copy=5, g=150, distance=0.035164775267126275, delta=0.019927253553753133, n_pairs=29), (149, 160, 171, 182, 193), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.sideflip', 'multi-flip (extra rotation) by mocomp.flips from motion: k=0.911')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "051706762aca401e"
    },
    "frontflip flips=2,window=4": {
        "motionFalse": "02ff0023ab6f6e8f",
        "auxFalse": "35265834e56c7c38",
        "miscFalse": "((127, 275), 117.0, (0.9226989141780153, 1.3181413059685934, 0.7, 9.810574514580802, 1.1331519716797471, 1.2280842149784186, 3.214065385174615, 0.016950969114654546, 6.037908624810454, 3.072293983812692, -3.0919835235705113, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 6.04 m/s vertically while the retimed take-off reaches 2.97 m/s: the linear momentum jumps at take-off by +100% of the retimed take-off momentum M k|v| (k|v| = 3.08 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.09 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.0813638206579874), -4.905287257290401, 1.2280842149784186, LandingJoin(u=86, f=157, copy=3, g=171, distance=3.573530360512223e-17, delta=0.048547590720019684, n_pairs=59), (166, 190, 214), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.frontflip', 'multi-flip (2) by mocomp.flips from motion: k=0.923')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "02ff0023ab6f6e8f",
        "auxTrue": "35265834e56c7c38",
        "miscTrue": "((127, 275), 117.0, (0.9226989141780153, 1.3181413059685934, 0.7, 9.810574514580802, 1.1331519716797471, 1.2280842149784186, 3.214065385174615, 0.016950969114654546, 6.037908624810454, 3.072293983812692, -3.0919835235705113, 'k = 0.70 k*: the flight keeps its retimed duration and both end levels, so it leaves at 6.04 m/s vertically while the retimed take-off reaches 2.97 m/s: the linear momentum jumps at take-off by +100% of the retimed take-off momentum M k|v| (k|v| = 3.08 m/s; p_jump_takeoff_rel), and the vertical velocity by -3.09 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.0813638206579874), -4.905287257290401, 1.2280842149784186, LandingJoin(u=86, f=157, copy=3, g=171, distance=3.573530360512223e-17, delta=0.048547590720019684, n_pairs=59), (166, 190, 214), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.frontflip', 'multi-flip (2) by mocomp.flips from motion: k=0.923')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "f956e016ee069a45"
    },
    "backflip flips=2,k=1.1": {
        "motionFalse": "300aaa0cb18f5b0c",
        "auxFalse": "68de6df64075e519",
        "miscFalse": "((108, 245), 118.0, (1.1, 1.392649303093901, 0.7898614515199534, 9.810002663212916, 1.2585215417491231, 1.1441104924992027, 3.1320923710282225, -0.06388029871845302, 5.556029459950381, 2.1107278518193366, -2.0089221979976633, 'k = 0.79 k*: the flight keeps its retimed duration and both end levels, so it leaves at 5.56 m/s vertically while the retimed take-off reaches 3.45 m/s: the linear momentum jumps at take-off by +60% of the retimed take-off momentum M k|v| (k|v| = 3.51 m/s; p_jump_takeoff_rel), and the vertical velocity by -2.01 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.5067079876995297), -4.905001331606458, 1.1441104924992027, LandingJoin(u=103, f=154, copy=3, g=172, distance=2.5777990853015343e-16, delta=-0.03811563049528921, n_pairs=54), (170, 200, 230), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (2) by mocomp.flips from motion: k=1.100')), ['assemble', 'reposition', 'retime', 'sequence', 'smooth'])",
        "motionTrue": "300aaa0cb18f5b0c",
        "auxTrue": "68de6df64075e519",
        "miscTrue": "((108, 245), 118.0, (1.1, 1.392649303093901, 0.7898614515199534, 9.810002663212916, 1.2585215417491231, 1.1441104924992027, 3.1320923710282225, -0.06388029871845302, 5.556029459950381, 2.1107278518193366, -2.0089221979976633, 'k = 0.79 k*: the flight keeps its retimed duration and both end levels, so it leaves at 5.56 m/s vertically while the retimed take-off reaches 3.45 m/s: the linear momentum jumps at take-off by +60% of the retimed take-off momentum M k|v| (k|v| = 3.51 m/s; p_jump_takeoff_rel), and the vertical velocity by -2.01 m/s at landing; k = k* (k_ratio=1, --k-ratio 1) keeps it continuous', 3.5067079876995297), -4.905001331606458, 1.1441104924992027, LandingJoin(u=103, f=154, copy=3, g=172, distance=2.5777990853015343e-16, delta=-0.03811563049528921, n_pairs=54), (170, 200, 230), 120.0, SourceInfo(path=None, format='generated', unit_scale=1.0, unit_reason='generated in metres', header_fps=120.0, notes=('mocomp.synth.backflip', 'multi-flip (2) by mocomp.flips from motion: k=1.100')), ['assemble', 'evaluate', 'reposition', 'retime', 'sequence', 'smooth'])",
        "report": "1f769fd5c21e7dab"
    }
}


def h(*arrs):
    m = hashlib.sha256()
    for a in arrs:
        if a is None:
            m.update(b"None"); continue
        a = np.ascontiguousarray(a)
        m.update(str(a.dtype).encode() + str(a.shape).encode()); m.update(a.tobytes())
    return m.hexdigest()[:16]

CASES = []
for name in ["backflip", "frontflip", "sideflip"]:
    for fl in (2, 3, 4):
        CASES.append((name, dict(flips=fl)))
CASES += [("backflip", dict(flips=2, seam_retime=False)), ("backflip", dict(flips=2, k_ratio=1.0)),
          ("backflip", dict(flips=3, height_change=-0.3, takeoff_height_change=0.2)),
          ("sideflip", dict(flips=None, extra_rotation=np.deg2rad(300))), ("frontflip", dict(flips=2, window=4)),
          ("backflip", dict(flips=2, k=1.1))]

def outputs():
    Ps = {n: prepare(synthetic(n).motion) for n in ["backflip", "frontflip", "sideflip"]}
    out = {}
    for name, kw in CASES:
        key = name + " " + ",".join(f"{k}={v}" for k, v in kw.items())
        d = {}
        for ev in (False, True):
            r = multiflip(Ps[name], evaluate=ev, **kw)
            d[f"motion{ev}"] = h(r.motion.root_positions, r.motion.rotations)
            d[f"aux{ev}"] = h(r.seq_positions, r.seq_times, r.speed, r.sequence.frames, r.sequence.extra,
                              r.sequence.copy, r.trajectory.c0, r.trajectory.velocity)
            d[f"misc{ev}"] = repr((r.flight, r.takeoff_time, dataclasses.astuple(r.plan), r.trajectory.a_y,
                                   r.trajectory.T_new, r.sequence.join, r.sequence.loop_seams, r.motion.fps,
                                   r.motion.source, sorted(r.timings)))
        rep = r.report.to_dict(); rep.pop("times_ms")
        d["report"] = hashlib.sha256(repr(rep).encode()).hexdigest()[:16]
        out[key] = d
    return out



@pytest.mark.skipif((np.__version__, numba.__version__) != (MADE_WITH["numpy"], MADE_WITH["numba"]),
                    reason=f"reference bits made with numpy {MADE_WITH['numpy']} / numba {MADE_WITH['numba']}")
def test_runtime_outputs_bit_identical_to_reference():
    got = outputs()
    assert set(got) == set(REFERENCE)
    bad = [(case, what) for case in REFERENCE for what in REFERENCE[case] if got[case][what] != REFERENCE[case][what]]
    assert not bad, f"run-time outputs changed: {bad}"


def test_hash_sees_a_one_ulp_change():
    a = np.linspace(0.0, 1.0, 7)
    b = a.copy()
    b[3] = np.nextafter(b[3], 2.0)
    assert h(a) != h(b) and h(a) == h(a.copy())


def test_trajectory_end_is_the_call_at_T_new_bit_for_bit():
    from mocomp.flips.reposition import flight_trajectory

    rng = np.random.default_rng(4)
    for _ in range(50):
        c0, (ax, az, ay, k, vy, T) = rng.normal(size=3), rng.normal(size=6)
        tr = flight_trajectory(c0, ax, az, -abs(ay), abs(k) + 0.3, vy, abs(T) + 0.1)
        ref = tr(np.array([tr.T_new]))[0]
        assert tr.end.tobytes() == ref.tobytes()


def test_compiled_reposition_equals_the_numpy_steps_bit_for_bit():
    from mocomp import datasets
    from mocomp.flips._kernels import AVAILABLE, reposition_nb
    from mocomp.flips.reposition import flight_trajectory

    if not AVAILABLE:
        pytest.skip("numba not available")
    P = prepare(datasets.load("backflip"))
    rng = np.random.default_rng(7)
    n_seq, N = 60, 80
    rp = rng.normal(size=(n_seq, 3))
    tau = np.sort(rng.uniform(0, n_seq - 1, N))
    i0 = np.minimum(np.floor(tau).astype(int), n_seq - 2)
    al = tau - i0
    tw = tau * 1.01
    rot_out = np.ascontiguousarray(P.rotations[rng.integers(0, P.rotations.shape[0], N)])
    traj = flight_trajectory(rng.normal(size=3), 0.3, -0.2, -4.9, 0.9, 3.0, 1.2)
    f0, f1, w_to, div = 10, 70, 9.5, 0.9 * 120.0
    r0 = rp[i0]
    ref = r0 + al[:, None] * (rp[i0 + 1] - r0)
    ref[f0:f1] = traj((tw[f0:f1] - w_to) / div) - P.com_eval.relative_numpy(rot_out[f0:f1])
    got, finite = reposition_nb(rp, i0, al, tw, f0, f1, w_to, div, traj, rot_out, P.com_eval)
    assert finite
    # the COM offset: compiled and numpy agree to rounding; with the compiled one, bit for bit
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    ref[f0:f1] = traj((tw[f0:f1] - w_to) / div) - P.com_eval.relative(rot_out[f0:f1])
    assert got.tobytes() == ref.tobytes()
    rp[i0[3], 1] = np.inf
    assert not reposition_nb(rp, i0, al, tw, f0, f1, w_to, div, traj, rot_out, P.com_eval)[1]
