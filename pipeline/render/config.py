"""The render stage's options (:class:`RenderConfig`) and the names its paths and fills take."""

from __future__ import annotations

from dataclasses import dataclass

from pipeline.options import option

FLARE_FALLBACKS = ("valid", "darkest")
"""``gnfr.transformer.FLARE_FALLBACKS`` without importing torch (a test keeps them equal)."""

NAMED_PATHS = ("inputs", "interpolate", "spiral")
FILLS = ("hybrid", "network")


INPUTS_FRAMES = "inputs_frames"
"""``RenderConfig.inputs_fill`` ``frame``: the novel frames at the flared photos' cameras,
WS/renders/inputs_frames/ (their camera path WS/renders/inputs_frames.json)."""


INPUTS_MIN_BLOB = 0.0005
"""``RenderConfig.depth_min_blob`` of the de-flared photos (`--path inputs`): chosen on fresh
flare draws of two development scenes (docs/history/fill.md, "Specks in the sky")."""


NOVEL_SOURCES_EQUAL_BELOW = 0.1
"""``RenderConfig.sources_equal_below`` of novel frames (camera paths, held-out cameras) when
not given. The de-flared photos always default to 0: their fill takes the sources' pixels,
where a mask's misses bring flare in, so the least flared sources serve them best
(docs/history/fmg.md, "Twenty-fifth session"). 0.1 since the full-width FMG shipped (the
twenty-sixth session); 0 before."""


INPUTS_SOURCES = 12
"""The de-flared photos' source count when ``n_sources`` is not given (or the model's own
count when it is larger; every other view when fewer): on lund, the one development scene
with more than 12 photos, 42 % of the points along the rays through the flare fall on flare
in every one of 6 sources and 27 % with 12; the de-flared photos' flare region rose 0.09 dB
on the development scenes' mean, lund 0.20 (docs/history/gnfr.md, "Sixty-seventh
session"). Novel frames keep the model's count (12 cost lund's held-out views 0.83 dB)."""


NOVEL_NEAREST_SOURCE = True
"""``RenderConfig.nearest_source`` of novel frames when not given: whether the input view
nearest a novel camera is always one of its sources, however flared. On since the
forty-ninth session, with the CPU's key blend (``NOVEL_CPU_FILL``), by the rule in
docs/history/fill.md, "Novel frames' sources near heavily flared photos"."""


NOVEL_NEAREST_COUNT = 2
"""``RenderConfig.nearest_count`` when not given: with ``NOVEL_NEAREST_SOURCE``, the two input
views nearest a novel camera are always among its sources. Since the eightieth session, by
the rule in docs/history/fill.md, "The two nearest photos as sources": the flared
development scenes' held-out views +0.05 dB on the mean (lund_k4 +0.15), the guard scenes'
unchanged."""


NOVEL_CPU_FILL = {"network_scale": 0.35, "agree_window": 3, "network_depth": "holes",
                  "key_blend": 0.5, "novel_agree": 0.12, "key_spot": 0.1}
"""The hybrid fill of novel frames on the CPU where the options are not given (``plan.
resolve_fill``): GN-FR's share at ``network_scale`` of the frame, its
own depth where the depth maps do not reach, the photos' agreement judged over 3x3 pixels.
Chosen by the forty-fifth session's rule on fresh development draws (docs/history/fill.md,
"The novel frames' fill on the frames' own depth"). The de-flared photos keep a 1-pixel
agreement; CUDA keeps GN-FR at full size with the depth maps' depth (never timed there).
``key_blend`` since the forty-ninth session, ``novel_agree`` (the photos' agreement
tolerance, 0.12 against ``photo_fill.AGREE``'s 0.08) since the fiftieth, ``key_spot`` (the
lean reaching past a twin and taking it too) since the eighty-first, each by its rule in
docs/history/fill.md."""


@dataclass
class RenderConfig:
    """Options of the render stage."""

    path: str = option("inputs", choices=NAMED_PATHS, suffix=".json")
    """inputs, interpolate, spiral, or a camera-path FILE.json (docs/camera_paths.md)."""
    frames: int | None = option(None, ge=1)
    """Frames of an interpolate / spiral path (default: seconds x fps)."""
    seconds: float = option(4.0, gt=0)
    """Length of an interpolate / spiral path when ``frames`` is not given."""
    fps: float = option(24.0, gt=0)
    """Frame rate used with ``seconds`` to count frames."""
    pace: str = option("image", choices=("image", "travel"))
    """How an interpolate path spreads its frames: ``image``, at an even pace of image
    motion (the depth maps' points; the default since the fifty-second session); ``travel``,
    at constant travel with turns weighing little (before it: on a street walk its frames'
    flow was more even; docs/camera_paths.md)."""
    tour: str = option("position", choices=("position", "view"))
    """How an interpolate path orders the photos it passes: ``position``, the shortest tour
    by camera position; ``view``, by position and viewing direction together (a step's
    travel over the scene's typical depth plus its turn in radians: the image motion it
    makes), so two photos taken from one spot looking apart are not neighbours on the tour
    (an opt-in: its rule failed on a small toy capture; docs/camera_paths.md)."""
    zoom: str = option("photos", choices=("photos", "fixed"))
    """An interpolate path's focal length: ``photos``, each frame at a photo has that
    photo's field of view (its focal length over its long side), and the frames between
    glide from one to the next; ``fixed``, every frame has the reference photo's (the first
    of the most common size), as before the ninety-eighth session. A capture whose photos'
    fields of view lie within ``plan.ZOOM_SPREAD`` of each other renders, and is recorded,
    as ``fixed`` (docs/camera_paths.md)."""
    source_fade: int = option(1, ge=0, le=12)
    """Novel paths: where a frame's sources (GN-FR's, or the photos its fill takes first)
    differ from the next frame's, the change is cross-faded over this many frames either
    side: each frame is the mean of its camera rendered with the sources of every frame
    within that many of it (a box over the path), so the frame does not jump where the set
    changes. A frame with another set in its window renders once per set (more time: 1.22
    images a frame on six development builds at 1). 0 = off, as before the fifty-third
    session. 1 by its rule: the largest step's warping error -16 % on the mean of six
    development builds, the frames 1.7 % less sharp; 2 took the largest step down 23 % but
    the sharpness 3.1 % (docs/history/fill.md, "Changes of a frame's sources cross-faded").
    Frames farther apart than ``FADE_STEP`` of the photos' spacing are not faded together (a
    JSON path's cut, held-out cameras; ``plan.fade_sources``), and a path whose fades would
    render more than ``fade_limit`` images a frame renders without them."""
    fade_limit: float = option(1.5, ge=0)
    """Novel paths: where the cross-fade (``source_fade``) would render more than this many
    images a frame over the path (its sources change at most frames: a densely photographed
    object), the path renders without it, and says so. 1.5 (the fade rule's own limit) by
    its rule: on two close development objects' spiral paths the fade took 2.08 images a
    frame and 6.1 % of the frames' sharpness for a largest step 15.6 % lower on one path of
    the two (docs/history/fill.md, "The cross-fade stepping back on a dense path"). 0: never
    steps back, as before the fifty-fifth session (``plan.fade_or_not``)."""
    fade_cut: float = option(0.0, ge=0)
    """Novel paths: a step between two frames is a cut, not faded across
    (``source_fade``), only where it is longer than ``FADE_STEP`` photo spacings and also
    longer than this many times the path's median step (a step much longer than the path's
    usual one). 0 (the default): the photos' spacing alone decides; on a densely photographed
    object a short path steps more than ``FADE_STEP`` spacings at most frames, and its
    changes of sources go unfaded (``plan.fade_sources``). Off by its rule: at 3, on two
    close development objects the steps' warping error -3.1 % and the largest step -23 %, but
    the frames 2.4 % less sharp (a long step's fade mixes in a render from farther photos;
    docs/history/fill.md, "The cross-fade's cut by the path's own steps")."""
    path_exposure: float = option(1.0, ge=0)
    """Novel frames of a model fine-tuned with its views' exposures evened out (the
    default): each frame's exposure (the median of the photos its fill takes first, the
    level of its photo fill at 0) is averaged with the other frames' by a Gaussian of the
    distance between their cameras, of this many photo spacings (the median distance
    between neighbouring photos); GN-FR's colours and the fill's photos (each by its own
    gain) are brought to it, so the video's exposure glides instead of jumping where a
    frame's sources change (a phone's auto exposure can differ by 1.6 EV between the photos
    of one walk), and GN-FR's share of a frame is at its photos' exposure. 1 by its rule: on
    six development builds the steps' warping error -6.5 % and the largest step -5.5 % on
    the mean, the left-out views +0.32 dB PSNR (docs/history/fill.md, "The video's exposure
    along the path, at its photos' level"). 0: GN-FR at its sources' median exposure, its
    fill at its photos' median, as before the fifty-fourth session
    (``plan.exposure_along_path``)."""
    source_hold: int = option(0, ge=0, le=12)
    """Novel paths: a frame keeps the frame before's choice of sources (GN-FR's and the
    photos its fill takes first) while every one of them stays among the views it would
    choose with this many more sources (and its fill's first photos among that many more of
    the nearest), and the photo nearest the frame is among both; otherwise it chooses anew.
    Fewer changes of sources, so fewer to cross-fade (``source_fade``), at the price of a
    farther view now and then. 0 = off: every frame chooses its own (``plan.hold_sources``).
    Off by its rule: at 1, 1.16 images a frame instead of 1.22 and the steps' warping error
    -1.0 % on six development builds, but the frames 0.95 % less sharp (docs/history/fill.md,
    "A frame's sources held along the path")."""
    size: tuple[int, int] | None = option(None, ge=1, sep="x", metavar="WIDTHxHEIGHT")
    """Render size (width, height) of novel frames; overrides ``scale``."""
    scale: float | None = option(None, gt=0)
    """Novel frames at this fraction of the input image size (default 1/4 on CPU, 1 on
    CUDA; a JSON path keeps its own sizes unless ``scale`` or ``size`` is given)."""
    chunk: int | None = option(None, ge=1)
    """Rays per forward pass (default: ``default_chunk`` of the device; lower it if memory
    runs out)."""
    device: str = option("auto", device=True)
    """auto (CUDA when available), cpu, cuda or cuda:N."""
    workers: int | None = option(None, ge=1)
    """On the CPU: processes that render the frames side by side, one thread each (default:
    one per thread torch would use, at least two frames each; 1 renders in this process with
    torch's threads, and holds the photos and the model once). The frames are the same but
    for rounding (threads sum in another order: a few values in a million 1 level apart); on
    the 2-core machine two one-thread processes rendered the sample's video frames 1.3x
    faster than one with two threads (``python benchmarks/render_speed.py``,
    docs/performance.md, "Video frames in two processes"). CUDA and ``compile`` render in
    this process."""
    samples: int | None = option(None, ge=1)
    """Samples per ray (default: the checkpoint's training value, else 64 CUDA / 32 CPU)."""
    blend: str = option("mask", choices=("mask", "none"))
    """inputs: ``mask`` renders and replaces only the flare region; ``none`` the full image."""
    dilate: float = option(0.0, ge=0)
    """inputs: the flare mask is grown by this fraction of the image's long side (at least
    one pixel). 0 since the seventeenth session (was 0.01: the grown ring traded clean
    photo for fill; docs/history/fill.md, "How far the fill reaches past the mask")."""
    feather: float = option(0.01, ge=0)
    """inputs: width of the soft blend edge as a fraction of the image's long side."""
    color_match: bool = True
    """inputs (with ``blend mask``): before blending, map the rendered fill's colours to the
    photo by a per-channel gain and offset fitted on the rendered pixels just outside the
    flare mask (the dilation ring, where both the render and the clean photo exist); this
    removes the fill's colour and exposure drift (docs/eval.md)."""
    flare_layer: float = option(0.01, ge=0)
    """inputs (with ``blend mask``): inside the flare region keep the photo's own pixels
    minus a smooth flare layer (the photo's difference from the fill, blurred by a Gaussian
    of this fraction of the long side), so the scene's detail seen through the flare stays;
    clipped pixels keep the fill. 0: replace the region by the fill (docs/depth.md). 0.12
    from the sixth session to the ninety-eighth; 0.01 since the ninety-ninth, by the rule in
    docs/history/fill.md, "A narrow flare layer" (most of the flare's light, streaks and
    spikes included, is coarser than 0.01 of the long side; the scene's finest texture is
    not)."""
    flare_layer_adapt: float = option(0.0, ge=0)
    """inputs: each connected part of the flare region gets a flare layer of this many times
    its equivalent radius (at most ``flare_layer``), so a compact ghost is measured at its own
    scale (0 = one width for all; docs/history/fill.md, "A layer per flare")."""
    clipped: str = option("any", choices=("any", "all"))
    """inputs, with the flare layer: a photo pixel counts as clipped (no detail left: the fill
    stays there) when ``any`` of its channels reaches 0.95 (also a bright blue sky) or only
    when ``all`` do (white: the flare's saturated core; docs/history/fill.md, "Clipped pixels")."""
    flare_layer_local: float = option(0.0, ge=0)
    """inputs: cap the flare layer by the photo's difference from the fill blurred at this
    much smaller fraction of the long side, so the wide layer does not carry a light's
    bright core into its dark surroundings (0 = off; docs/history/fill.md, "A black halo")."""
    full_res: bool = False
    """inputs: also render the flare region at the original photo's full resolution and
    blend it into the original (into WS/deflared_full/)."""
    n_sources: int | None = option(None, ge=1)
    """Source views per frame, the least flared of the nearest ``pool`` (default: the
    checkpoint's eval_views, else 10; for the de-flared photos at least ``INPUTS_SOURCES``,
    12)."""
    pool: int = option(20, ge=1)
    """Nearest views from which the ``n_sources`` least-flared are kept."""
    sources_equal_below: float | None = option(None, ge=0, le=1)
    """Flare fractions up to this count as none when sources are chosen, so the nearest of
    those views win (0.1: every view the 10 % target rule trains on is an equally good
    source; 0: the least flared first, fractions within 2 points equal). Default:
    ``NOVEL_SOURCES_EQUAL_BELOW`` for novel frames, 0 for the de-flared photos."""
    nearest_source: bool | None = option(None, flag="--nearest-source/--no-nearest-source")
    """Novel frames: the input view nearest the camera is always one of its sources, however
    flared (its mask keeps its flare out of GN-FR's attention, and the photo fill takes a
    pixel only where a second photo agrees), so a frame at a flared photo's position is drawn
    from that photo. Default: ``NOVEL_NEAREST_SOURCE``. The de-flared photos never take
    themselves; for them the option does nothing."""
    nearest_count: int | None = option(None, ge=1, le=8)
    """With ``nearest_source``: how many of the input views nearest a novel camera are
    always among its sources (each in place of the farthest chosen). 2 keeps both photos a
    frame between two photos of the tour lies between, where a photo taken from the same
    spot, turned the way the frame turns, is as near as the nearest but more flared
    (docs/history/fill.md, "The two nearest photos as sources"). Default:
    ``NOVEL_NEAREST_COUNT``; 1 renders as before the eightieth session."""
    source_scale: float | None = option(None, gt=0)
    """Resolution of the encoded source views relative to WS/images (default: the
    checkpoint's training value, else 1)."""
    full_res_colour: bool | None = None
    """Sample the sources' colours at the full size of WS/images while the encoder sees them
    at ``source_scale`` (default: as the checkpoint was trained, else off)."""
    compile: bool = False
    """Compile GN-FR's forward pass with ``torch.compile`` (chunks padded to one shape so it
    compiles once). On the 2-core CPU it made GN-FR's rays 1.3x faster after about 20 s of
    compiling (`python benchmarks/render_compile.py`, docs/results/render_compile_cpu.json):
    worth it where GN-FR draws most pixels (``--fill network``, large frames), not for the
    default hybrid video of a small scene. Needs a C++ compiler on CPU."""
    bf16: bool | None = option(None, flag="--bf16/--no-bf16")
    """On the CPU: GN-FR's forward pass under bf16 autocast, as CUDA always renders. Default:
    on where the CPU has native bf16 (AVX512-BF16 or AMX), fp32 elsewhere, where bf16 is
    emulated and about ten times slower (``gnfr.renderer.cpu_bf16``; judged with the
    fine-tune's on the development scenes). On this EPYC the sample's frames rendered 1.39x
    faster; they change by more than rounding (12 % of the values, a few pixels by far
    more) (`python benchmarks/render_bf16.py`, docs/performance.md, "bf16 on the CPU")."""
    checkpoint: str | None = None
    """Model weights (default: the latest checkpoint in WS/model/)."""
    flare_fallback: str | None = option(None, choices=FLARE_FALLBACKS)
    """What a point on flare in every source that sees it attends: valid | darkest
    (``gnfr.transformer.FLARE_FALLBACKS``). Default: the model's, as it was fine-tuned."""
    fill: str = option("hybrid", choices=FILLS)
    """``hybrid``: where WS/depth exists (`deflare-scene depth`), pixels are taken from the
    nearest photos warped by depth wherever ``min_support`` of them agree (flare masks and
    occlusions respected), and GN-FR renders only the rest; ``network``: GN-FR renders every
    pixel (docs/depth.md)."""
    min_support: int = option(2, ge=1)
    """hybrid: photos that must agree on a pixel's colour before it is taken from them."""
    photo_sources: int = option(4, ge=1)
    """hybrid: nearest clean photos warped into each image."""
    agree_window: int | None = option(None, ge=1, odd=True)
    """hybrid: a photo agrees with the others at a pixel when its colour difference from
    their median, averaged over this window around the pixel, is within the agreement
    tolerance (1 = the pixel alone; docs/history/fill.md, "Agreement over a patch").
    Default: 3 for novel frames on the CPU (``NOVEL_CPU_FILL``), 1 for the de-flared photos
    and on CUDA."""
    novel_agree: float | None = option(None, gt=0, le=1)
    """hybrid novel frames: the agreement tolerance, the largest channel difference (0..1
    colours) from the warped photos' median at which a photo agrees (``stereo.fuse``'s
    ``agree``). Default: 0.12 on the CPU (``NOVEL_CPU_FILL``; docs/history/fill.md, "A
    looser agreement for the novel frames"), ``photo_fill.AGREE`` (0.08) on CUDA (not
    measured there); the de-flared photos always use 0.08."""
    photo_fallback: int = option(0, ge=0)
    """hybrid: where fewer than ``min_support`` of the nearest ``photo_sources`` photos agree,
    fuse the nearest ``photo_sources`` + this many of the image's sources and take the pixel
    from them if ``min_support`` agree (0 = off; passed its rule on the development scenes
    but failed the sample's product test: docs/history/fill.md, "Farther photos where the nearest
    disagree")."""
    network_scale: float | None = option(None, gt=0)
    """hybrid novel frames: GN-FR renders the pixels the photos do not cover at this
    fraction of the frame size, upsampled under the photos' detail (default:
    ``NOVEL_CPU_FILL``'s on CPU, 1 on CUDA)."""
    beyond_planes: int = option(0, ge=0, le=64)
    """hybrid: planes past the far bound (out to 100 times it) in the sweep that finds a depth
    where no depth map reaches, so distant scenery and the sky can be taken from the photos
    (0 = off; docs/history/fill.md, "Beyond the far bound")."""
    close_holes: float = option(0.0, ge=0, le=0.1)
    """hybrid novel frames: holes in the photos' agreed region whose pixels all lie within
    this fraction of the frame's long side of agreed pixels are filled from the photo
    pixels around them instead of by GN-FR at ``network_scale`` (0 = off; docs/history/fill.md,
    "Small holes")."""
    sharp_holes: float = option(0.0, ge=0, le=0.1)
    """hybrid novel frames: holes in the photos' agreed region whose pixels all lie within
    this fraction of the frame's long side of agreed pixels are GN-FR's with a hard edge;
    only wider holes erode and feather the photos around them (0 = every hole does;
    docs/history/fill.md, "Feathered holes")."""
    network_vote: float = option(0.0, ge=0, le=1)
    """hybrid novel frames: where fewer than ``min_support`` photos agree, the photo whose
    colour, brought to GN-FR's ``network_scale``, lies closest to GN-FR's render and within
    this (largest channel difference, 0..1 colours) is taken there at full resolution: the
    network vouches for the colour, the photo adds the detail (0 = off; docs/history/fill.md,
    "The network's vote")."""
    from_deflared: bool = option(False, flag="--from-deflared/--no-from-deflared")
    """novel frames: GN-FR's sources read each photo's flare region from its de-flared photo
    (WS/deflared, ``render --path inputs``, which must be up to date; blended in as that
    photo's fill was), colours and features, the flare masks kept: where every source is
    flared at a point, GN-FR attends to the de-flared fills instead of the flare. The photo
    fill and the key blend read the photos as they are (``sources.with_deflared``). Off:
    judged in the eighty-eighth session, the frames' changed pixels -0.005 dB on the
    development mean, one scene of three up (docs/history/fill.md, "Novel frames' network
    sources from the de-flared photos")."""
    source_grow: float = option(0.0, ge=0, le=0.2)
    """novel frames: each source photo's flare mask grown by this fraction of its long side
    (``pipeline.ws_files.grow_mask``) for GN-FR's Point Sampler and the photo fill, so the
    faint glow just past a mask is not taken as scene (0 = the masks as they are; the
    de-flared photos keep theirs: ``--dilate``). 0 by default: 0.02 failed its rule in the
    eighty-eighth session, whole frames -0.129 dB on the development mean, every scene lower
    (docs/history/fill.md, "Novel frames' sources with their masks grown")."""
    unseen_below: float = option(0.5, ge=0, le=1)
    """novel frames: pixels whose ray lies inside none of the frame's sources over less than
    this share of its samples (past every photo's frame edge) are drawn from the frame around
    them (Telea inpainting), blended in by how little is seen, instead of GN-FR's guess from
    zero features (a dark smear; ``pipeline.render.unseen``). 0 = off, as before the
    eighty-third session (docs/history/fill.md, "Where no source sees")."""
    harmonize: float = option(0.0, ge=0, le=0.2)
    """hybrid novel frames: before the warped photos are fused, each is brought to their
    per-pixel median by a smooth local offset, its difference from the median averaged by a
    Gaussian of this fraction of the frame's long side, so the fused colour does not jump
    where the set of agreeing photos changes (vignetting, a sky's gradient; 0 = off;
    ``pipeline.stereo.harmonize_sources``, docs/depth.md)."""
    key_blend: float | None = option(None, ge=0, le=1)
    """hybrid novel frames: near an input photo's camera the frame leans to that photo
    warped into it (its flare masks respected), fully at the photo's own camera and less
    with distance, to none at this fraction of the way to the photo's nearest neighbour
    camera (0 = off), so the video passes through each photo as sharp as the photo
    (``pipeline.photo_fill.lean_to_nearest``). Default: 0.5 on the CPU
    (``NOVEL_CPU_FILL``; docs/history/fill.md, "Novel frames' sources near heavily flared
    photos"), 0 on CUDA (not measured there) and for the de-flared photos."""
    key_power: float = option(1.0, gt=0, le=8)
    """hybrid novel frames, with ``key_blend``: how the lean falls from the photo's camera to
    the reach, ``1 - x ** key_power`` at the fraction ``x`` of the way (1: linearly; above 1
    it stays near the photo longer and falls faster near the reach; docs/history/fill.md,
    "The key blend's falloff")."""
    key_spot: float | None = option(None, ge=0, le=0.5)
    """hybrid novel frames, with ``key_blend``: the input photos standing within this
    fraction of the median distance between the cameras of a frame's nearest photo count as
    taken from its spot (a twin, turned apart): the lean's reach is measured past them, and
    the frame leans to each of them where the nearer ones do not see it (0 = off: the reach
    ends at the twin, a few thousandths of a unit away). Default: 0.1 on the CPU
    (``NOVEL_CPU_FILL``; docs/history/fill.md, "The key blend beside a twin"), 0 on CUDA
    (no key blend there) and for the de-flared photos."""
    key_occlusion: bool = option(False, flag="--key-occlusion/--no-key-occlusion")
    """hybrid novel frames, with ``key_blend``: the frame leans to its nearest photo only
    where that photo passes the fill's occlusion test against its own depth map (off: wherever
    it sees the frame outside its flare mask; docs/history/fill.md, "The key blend's reach
    and its occlusion test")."""
    inputs_fill: str | None = option(None, choices=("photos", "frame"))
    """inputs (hybrid fill): what fills a de-flared photo's flare region before the ring
    check, the colour match and the flare layer: ``photos``, its own photo fill (the
    neighbours warped by depth where they agree, GN-FR at full size elsewhere); ``frame``,
    the video's frame drawn at the photo's own camera first (WS/renders/inputs_frames, the
    novel frames' fill and options; ``pipeline.render.inputs.frame_fill``), GN-FR at full
    size only where the ring check turns it down (docs/history/fill.md, "The de-flared
    photos filled as the video's frame at their camera"). Default: ``frame`` on the CPU
    since the ninety-ninth session (docs/history/fill.md, "A narrow flare layer"),
    ``photos`` on CUDA (not measured there); ``photos`` where GN-FR renders every pixel."""
    lean_deflared: bool | None = option(None, flag="--lean-deflared/--no-lean-deflared")
    """hybrid novel frames, with ``key_blend``: the photos the frame leans to (its nearest
    and those at its spot) are read de-flared (WS/deflared, ``render --path inputs``, which
    must be up to date; their flare regions blended in as the de-flared photos blend them),
    flare regions included, in the photo fill too: at a photo's own camera the frame is that
    photo's de-flared photo instead of GN-FR's render at ``network_scale`` inside its flare
    mask (``pipeline.render.fill.lean_deflared_views``). Off: the photos as they are,
    their flare masks respected. Default: on for the CPU's hybrid frames with the key blend
    where the de-flared photos are up to date (a line says so where they are not), off
    otherwise (docs/history/fill.md, "The frames at the photos lean to the de-flared
    photos, again"); the frames the de-flared photos take as their fill never lean."""
    network_depth: str | None = option(None, choices=("off", "holes", "all"))
    """hybrid novel frames: GN-FR renders every pixel at ``network_scale`` with its depth
    first, and the photos are warped through that depth: ``holes``, where the photos' depth
    maps do not reach (instead of the plane sweep's and the interpolation's); ``all``, at
    every pixel (the depth maps unused); ``off``: the depth maps, sweep and interpolation
    (docs/history/fill.md, "GN-FR's own depth for the photos"). Default: ``holes`` on the
    CPU (``NOVEL_CPU_FILL``), ``off`` on CUDA."""
    depth_min_blob: float | None = option(None, ge=0, lt=1)
    """hybrid: islands of the photos' depth maps (connected within one plane step) smaller
    than this fraction of the image are left out when the render reads them
    (``pipeline.stereo.remove_specks``; 0 = off). Default: ``INPUTS_MIN_BLOB`` for `--path
    inputs` (the de-flared photos), 0 for novel paths (docs/history/fill.md, "Specks in the
    sky")."""
    depth_samples: int | None = option(None, ge=0)
    """hybrid: rays whose surface depth the photos confirm (``depth_support``) are sampled
    with this many samples in a band around it instead of the full near-far range
    (default: 0 = off for novel frames on the CPU, a third of ``samples`` for the de-flared
    photos and on CUDA; ``plan.depth_samples``)."""
    depth_support: int = option(2, ge=1)
    """hybrid: photos that must agree on a pixel before its ray is sampled around their
    depth (docs/depth.md: 2 was the best worst case on the development scenes)."""
    band_rejected: bool = option(True, flag="--band-rejected/--no-band-rejected")
    """hybrid, de-flared photos: the rays of a flare region whose photo fill failed the ring
    check (``pipeline.render.inputs.check_on_ring``: on the clean pixels around the region
    the warped photos show another surface) are still sampled in the band around the
    photos' depth there; off: along the whole ray, as the network fill samples them
    (docs/history/fill.md, "Where the sample's gap comes from")."""

    def equal_below(self, novel: bool) -> float:
        """``sources_equal_below`` as it applies: the option when given, else
        ``NOVEL_SOURCES_EQUAL_BELOW`` for a novel frame and 0 for a de-flared photo. The one
        place that default is resolved (the render records it for novel paths, the source
        choice uses it)."""
        if self.sources_equal_below is not None:
            return float(self.sources_equal_below)
        return NOVEL_SOURCES_EQUAL_BELOW if novel else 0.0

    def source_count(self, eval_views: int | None) -> int:
        """``n_sources`` as it applies: the option when given, else the model's
        ``eval_views`` (10 without one), at least ``INPUTS_SOURCES`` for the de-flared
        photos (``path`` inputs)."""
        if self.n_sources:
            return int(self.n_sources)
        n = int(eval_views or 10)
        return max(n, INPUTS_SOURCES) if self.path == "inputs" else n

    def keeps_nearest(self) -> bool:
        """``nearest_source`` as it applies to a novel frame: the option when given, else
        ``NOVEL_NEAREST_SOURCE``."""
        return NOVEL_NEAREST_SOURCE if self.nearest_source is None else self.nearest_source

    def nearest_n(self) -> int:
        """``nearest_count`` as it applies to a novel frame: the option when given, else
        ``NOVEL_NEAREST_COUNT``."""
        return NOVEL_NEAREST_COUNT if self.nearest_count is None else int(self.nearest_count)
