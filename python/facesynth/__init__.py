"""facesynth: synthetic faces with exact labels, generated in memory (docs/python.md).

    gen = facesynth.Generator(config={"pose.yaw.max": 60}, seed=1, size=256, workers=2)
    batch = gen.batch(0, 32)      # dict of numpy arrays, leading dimension 32
    sample = gen[5]               # one sample, the same as sample 5 of `facesynth synth`
"""

import json
import math
import os

from . import _facesynth

__all__ = ["Generator", "worker_shard", "Model", "Renderer", "fit", "Detector", "Tracker", "Frontaliser", "frontalise", "nme", "nme_summary", "eval_fit", "eval_frontalise", "eval_realism"]



def _settings_json(config):
    def plain(value, key):
        if isinstance(value, dict):
            return {str(k): plain(v, f"{key}.{k}" if key else str(k)) for k, v in value.items()}
        if hasattr(value, "item") and not isinstance(value, (list, tuple)):  # numpy scalars as the numbers they hold
            value = value.item()
        if isinstance(value, os.PathLike):
            value = os.fspath(value)
        if isinstance(value, float) and not math.isfinite(value):
            raise ValueError(f"config: config key '{key}' must be a finite number, got {value}")
        if not isinstance(value, (bool, int, float, str, list, tuple, type(None))):
            raise ValueError(f"config: config key '{key}' must be a number, boolean or string, got {type(value).__name__}")
        return value

    return json.dumps(plain(config, ""))


class Generator:
    """Renders synthetic samples on C++ threads (the GIL is released while they work).

    config:  None (synth's defaults), a dict of config keys (nested like TOML tables, or dotted:
             {"pose": {"yaw": {"max": 60}}} or {"pose.yaw.max": 60}), or the path of a TOML file.
    model:   "builtin", a model file or a model folder (default: the config's model).
    seed:    the dataset seed (default: the config's); sample i depends only on (config, seed, i).
    size:    an int (square) or (width, height) in pixels (default: the config's camera size).
    workers: render threads, each with its own GL context.

    Sample i equals sample i of `facesynth synth` with the same config and seed.
    """

    def __init__(self, config=None, model=None, seed=None, size=None, workers=2):
        config_file, settings = "", ""
        if isinstance(config, (str, os.PathLike)):
            config_file = os.fspath(config)
            if not os.path.isfile(config_file):
                raise FileNotFoundError(f"{config_file}: config file not found")
        elif isinstance(config, dict):
            settings = _settings_json(config)
        elif config is not None:
            raise TypeError(f"config must be a dict, a TOML file path or None, not {type(config).__name__}")
        if size is not None:
            size = (size, size) if isinstance(size, int) else tuple(size)
            if len(size) != 2 or not all(isinstance(s, int) and s > 0 for s in size):
                raise ValueError(f"size must be a positive int or (width, height), got {size!r}")
        if not isinstance(workers, int) or workers < 1:
            raise ValueError(f"workers must be a positive int, got {workers!r}")
        if model is not None:
            model = os.fspath(model)
        self._core = _facesynth.Generator(config_file, settings, model, seed, size, workers)

    def batch(self, start, n):
        """Samples start .. start + n - 1 as a dict of numpy arrays, each with leading dimension n:
        image (n,H,W,3) uint8 RGB; landmarks (n,68,2) float32, 0-based pixels, of the config's
        landmark mode; landmarks_3d (n,68,3) float32, model space, mm; visible (n,68) bool;
        pose (n,3) float32 yaw, pitch, roll in degrees; alpha (n,K) and expression (n,E) float32;
        camera (n,3,4) float64, model space to homogeneous pixels; fov (n,) float32 degrees; and
        with output.mask / output.labels / output.depth / output.normals: mask (n,H,W) uint8,
        labels (n,H,W) uint8 region ids, depth (n,H,W) float32 mm, normals (n,H,W,3) float32."""
        return self._core.batch(_index(start, "start"), _index(n, "n"))

    def __getitem__(self, index):
        index = _index(index, "index")
        return {key: value[0] for key, value in self._core.batch(index, 1).items()}

    def __len__(self):
        """The config's count: the length of the fixed range that `facesynth synth` would write."""
        return self._core.count

    def batches(self, batch_size, start=0, stop=None, shard=(0, 1)):
        """Yields batches of batch_size consecutive samples from start, endlessly when stop is None,
        else up to stop (the last batch may be shorter). shard=(k, n) keeps batches k, k + n, ...,
        so n loader workers (see worker_shard) together yield every batch exactly once."""
        batch_size, start = _index(batch_size, "batch_size"), _index(start, "start")
        if batch_size < 1:
            raise ValueError(f"batch_size must be at least 1, got {batch_size}")
        k, n = shard
        if not (isinstance(k, int) and isinstance(n, int) and 0 <= k < n):
            raise ValueError(f"shard must be (k, n) with 0 <= k < n, got {shard!r}")
        first = start + k * batch_size
        while stop is None or first < stop:
            count = batch_size if stop is None else min(batch_size, stop - first)
            yield self._core.batch(first, count)
            first += n * batch_size

    @property
    def config(self):
        """The resolved configuration as nested dicts (every key)."""
        return json.loads(self._core.config_json)

    @property
    def config_toml(self):
        """The resolved configuration as a commented TOML document (`facesynth synth --config` reads it)."""
        return self._core.config_toml

    seed = property(lambda self: self._core.seed)
    size = property(lambda self: self._core.size, doc="(width, height)")
    workers = property(lambda self: self._core.workers)
    model_name = property(lambda self: self._core.model_name)
    renderer = property(lambda self: self._core.renderer, doc="the GL renderer each worker uses")


def worker_shard():
    """(k, n) for the current PyTorch DataLoader worker, (0, 1) outside one or without torch
    (torch is not imported here unless the caller already has)."""
    import sys

    data = sys.modules.get("torch.utils.data")
    info = data.get_worker_info() if data is not None else None
    return (0, 1) if info is None else (info.id, info.num_workers)


class Model(_facesynth.Model):
    """A morphable model: "builtin", a model file or a model folder (as --model).

    model.vertices(alpha=None, expression=None) -> (V, 3) float32, model space, mm (coefficients in
    σ units or blendshape weights; fewer than the model has leaves the rest at 0);
    model.landmarks(vertices) -> (68, 3) float64; model.triangles -> (T, 3) int32;
    model.sample(seed, truncation=3) -> {"alpha", "colour"}: the random face of `facesynth render --seed`;
    name, checksum, num_vertices, num_shape_components, num_expression_components."""

    def __init__(self, spec="builtin"):
        super().__init__(os.fspath(spec))


class Renderer:
    """Renders given instances of a model as `facesynth render` does (the mesh framed in the image,
    the renderer's default lighting), on one GL context:

        r = facesynth.Renderer("builtin")
        out = r.render(alpha=a, expression=e, yaw=30, size=256)

    render(alpha=None, expression=None, colour=None, yaw=0, pitch=0, roll=0, size=256, fov=30,
    distance=0, orthographic=False) returns image (H,W,3) uint8 RGB, mask (H,W) uint8, depth (H,W)
    float32 mm, normals (H,W,3) float32, labels (H,W) uint8 region ids, landmarks_fixed and
    landmarks_contour (68,2) float64, visible_fixed and visible_contour (68,) bool, and camera
    (3,4) float64 (model space to homogeneous pixels). distance=0 fits the face in 80 % of the image."""

    def __init__(self, model="builtin", antialiasing="msaa", samples=0):
        self._core = _facesynth.Renderer(_model(model), antialiasing, int(samples))

    def render(self, alpha=None, expression=None, colour=None, yaw=0.0, pitch=0.0, roll=0.0, size=256, fov=30.0, distance=0.0,
               orthographic=False):
        size = (size, size) if isinstance(size, int) else tuple(size)
        return self._core.render(alpha, expression, colour, float(yaw), float(pitch), float(roll), size, float(fov), float(distance),
                                 bool(orthographic))


def _model(model):
    return model if isinstance(model, _facesynth.Model) else Model(model)


def fit(landmarks, model="builtin", image_size=None, jaw="contour", lambda_=30.0, refine=False, focal=0.0, sigma=3.0,
        expression=True):
    """Fits the model to 68 landmarks ((68, 2) float, 0-based pixels), as `facesynth fit` does with
    the same options. Returns fit.json's keys (yaw_deg, pitch_deg, roll_deg, rotation,
    reprojection_rms_px, affine_camera, ...) with alpha and expression as float32 arrays, and
    projected (68, 2) and vertices_px (V, 2): the fitted landmarks and vertices in the image.
    image_size=(width, height) and focal (px, 0 = estimated) are used by refine. Unusable
    landmarks raise ValueError. Pass a Model to fit many faces: it keeps the fitter's precomputed
    bases (about 5 ms of a 7 ms fit), where a model name loads the model every call."""
    size = None if image_size is None else tuple(image_size)
    return _facesynth.fit(landmarks, _model(model), size, jaw, float(lambda_), bool(refine), float(focal), float(sigma), bool(expression))


class Detector(_facesynth.Detector):
    """Face detection and 68 landmarks: regressor = "dlib" (dlib's predictor) or an .sdm file from
    `facesynth train`; detector = "auto" (the one the regressor was trained with) or a detector name
    as --detector takes. detect(image) takes an (H, W, 3) RGB or (H, W) grey uint8 array and returns
    every face found, largest first: {"box": (x, y, w, h), "landmarks": (68, 2), "view": ...}."""

    def __init__(self, regressor="dlib", detector="auto"):
        super().__init__(os.fspath(regressor), detector)


class Tracker:
    """Follows faces over the frames of a video given one at a time, as `facesynth track` does (the same
    tracker, docs/track.md): the detector runs every `detect_every` frames or when a face is lost,
    landmarks are smoothed without lag, and each face's identity is fused over its frames.

    process(image, time_s=None) takes an (H, W, 3) RGB or (H, W) grey uint8 array and returns the faces
    followed in it, each a dict with the keys of faces.jsonl's records: id (kept across frames),
    landmarks (68, 2), box (x, y, w, h), detected (this frame's box came from the detector), fit_error,
    yaw, pitch, roll (degrees), expression, identity and identity_frames. time_s defaults to the frame
    count / fps; given, it must increase. `counters` holds frames, detector_runs,
    fallback_detector_runs, losses, reacquired, cuts and reidentified.

    regressor: "dlib" or an .sdm file; detector: "auto" or a name as --detector takes; track=False is
    the per-frame baseline (the detector every frame, no smoothing), smooth=False leaves the 1-euro
    filter out; cut_threshold and max_reid_distance are --cut-threshold and --max-reid-distance (scene
    cuts, re-identification by appearance; 0 turns either off)."""

    def __init__(self, regressor="dlib", model="builtin", detector="auto", detect_every=5, max_faces=1, track=True, smooth=True,
                 max_fit_error=0.08, multiview_fallback=True, fps=30.0, cut_threshold=18.0, max_reid_distance=70.0):
        if not (isinstance(fps, (int, float)) and math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        self._fps = float(fps)
        self._tracker = _facesynth.Tracker(_model(model), os.fspath(regressor), detector, int(detect_every), int(max_faces), bool(track),
                                           bool(smooth), float(max_fit_error), bool(multiview_fallback), float(cut_threshold),
                                           float(max_reid_distance))

    def process(self, image, time_s=None):
        if time_s is None:
            time_s = self._tracker.counters["frames"] / self._fps
        return self._tracker.process(image, float(time_s))

    @property
    def counters(self):
        return self._tracker.counters


class Frontaliser(_facesynth.Frontaliser):
    """Fits a face, extracts its isomap and renders it frontal (as `facesynth frontalise`):
    frontalise(image, landmarks) -> {"frontal": (S, S, 3) uint8 RGB, "mask": (S, S) uint8,
    "isomap": (N, N, 4) uint8 RGBA, "fit": the fit's keys}."""

    def __init__(self, model="builtin", size=256, mirror_fill=False):
        super().__init__(_model(model), int(size), bool(mirror_fill))


def frontalise(image, landmarks, model="builtin", size=256, mirror_fill=False):
    """One face frontalised: Frontaliser(model, size, mirror_fill).frontalise(image, landmarks). For
    many faces keep a Frontaliser, which holds the model's precomputed maps and a renderer."""
    return Frontaliser(model, size, mirror_fill).frontalise(image, landmarks)


def nme(predicted, truth):
    """Mean point-to-point error of 68 landmarks ((68, 2) float arrays) over the inter-ocular
    distance (outer eye corners), as `facesynth eval landmarks` computes it per face."""
    return _facesynth.nme(predicted, truth)


def nme_summary(nmes, threshold=0.08):
    """The summary `facesynth eval landmarks --json` reports for per-face NMEs (inf for a face the
    detector missed): count, nme_mean (misses left out), nme_median (misses as inf), auc_008 and
    failure_rate_008 (misses as failures); the threshold replaces 0.08 in the last two."""
    return _facesynth.nme_summary(nmes, float(threshold))


def eval_fit(model="builtin", data=None, mode="contour", count=300, seed=424242, noise=0.0, landmarks="68", refine=False,
             visible_only=False, lambda_=30.0, sigma=1.0, max_yaw=None):
    """`facesynth eval fit` with the same options: fit accuracy against ground truth on `count` cases
    generated in code (data=None), or on a `facesynth synth` dataset folder fitted from its true
    landmarks (mode "contour" or "fixed" labels). Returns the keys of its --json (vertex_rmse_mm,
    yaw_mae_deg, ... overall and per yaw bin); the timing keys (ms_per_fit, cpu_ms_per_fit) vary run
    to run. A bad option raises ValueError; a dataset sample that cannot be read or fitted raises
    RuntimeError naming every such sample, as the CLI exits 1."""
    return _facesynth.eval_fit(_model(model), "" if data is None else os.fspath(data), mode, int(count), int(seed), float(noise),
                               str(landmarks), bool(refine), bool(visible_only), float(lambda_), float(sigma),
                               None if max_yaw is None else float(max_yaw))


def eval_frontalise(model="builtin", count=10, seed=20261122, isomap_size=512, size=256, image_size=384, fov=8.0, framing=1.5,
                    lighting="unlit"):
    """`facesynth eval frontalise` with the same options, from true landmarks: posed renders of known
    textured faces (each identity once per 10° yaw bin) frontalised and compared with their true
    frontal render. Returns the keys of its --json (psnr, ssim, isomap coverage ... overall and per
    yaw bin, with and without mirror fill). The CLI's --regressor (detected landmarks) is CLI only."""
    return _facesynth.eval_frontalise(_model(model), int(count), int(seed), int(isomap_size), int(size), int(image_size), float(fov),
                                      float(framing), lighting)


def eval_realism(data, photos=None, regressor="dlib", detector="dlib", max_yaw=20.0, match_face_size=False):
    """`facesynth eval realism` with the same options: a real-trained predictor (regressor) on the
    near-frontal renders of a synth dataset and, with photos, on near-frontal annotated photographs
    (with match_face_size, scaled to the renders' median face size first, as --match-face-size).
    Returns the keys of its --json (nme_ratio, renders_nme_mean, photos_nme_mean, per-landmark
    bias ...); unreadable images become warnings and count as misses."""
    return _facesynth.eval_realism(os.fspath(data), "" if photos is None else os.fspath(photos), os.fspath(regressor), detector,
                                   float(max_yaw), bool(match_face_size))


def _index(value, name):
    try:
        value = value.__index__()
    except AttributeError:
        raise TypeError(f"{name} must be an int, not {type(value).__name__}") from None
    if value < 0:
        raise ValueError(f"{name} must not be negative, got {value}")
    return value
