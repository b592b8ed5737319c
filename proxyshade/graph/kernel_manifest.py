"""Kernel signatures the demo graphs reach, for ``warmup.precompile``: written by
``python -m proxyshade.graph.warmup --write-manifest`` (numba 0.68.1), do not edit.
(kernel, argument types, compile seconds, (kernel, argument types) compiled inside);
CALLERS: the node type whose compute first called each entry (by index); VARIANTS: that
node's ``warmup.node_variant``."""
ENTRIES = [
    ('proxyshade.kernels.raster._setup_pass', "(Array(float64, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Named('proxyshade.kernels.raster.Camera', (float64, float64, float64, float64, bool, int64, int64)), bool, Array(int64, 1, 'C', False, aligned=True), Array(int64, 3, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True))", 1.32, (
        ('proxyshade.kernels.raster._clip', "(Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True))"),
        ('proxyshade.kernels.raster._polygon', "(Array(float64, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), int64, Array(float64, 2, 'C', False, aligned=True), Named('proxyshade.kernels.raster.Camera', (float64, float64, float64, float64, bool, int64, int64)), Array(float64, 3, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True))"),
    )),
    ('proxyshade.kernels.raster.bin_rows', "(Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), int64, int64)", 0.31, (
    )),
    ('proxyshade.kernels.raster._raster_bands', "(Array(int64, 3, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), int64, int64, Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True))", 1.09, (
        ('proxyshade.kernels.raster._owns', '(int64, int64, int64, int64)'),
    )),
    ('proxyshade.kernels.raster._interpolate', "(Array(float64, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), float64, bool, bool, Array(float32, 3, 'C', False, aligned=True))", 0.43, (
    )),
    ('proxyshade.kernels.voting._vote_blocks', "(Array(int32, 2, 'C', False, aligned=True), int64, int64, Array(int32, 2, 'C', False, aligned=True), int64, int64)", 0.13, (
    )),
    ('proxyshade.kernels.voting._vote_stack_level', "(Array(int32, 2, 'C', False, aligned=True), int64, int64, Array(int32, 2, 'C', False, aligned=True))", 0.28, (
    )),
    ('proxyshade.kernels.features._windows', "(Array(int32, 2, 'C', False, aligned=True), int64, Array(int32, 3, 'C', False, aligned=True), int64, int64)", 0.09, (
    )),
    ('proxyshade.kernels.chamfer._masks_from_windows', "(Array(int32, 3, 'C', False, aligned=True), int64, Array(uint32, 3, 'C', False, aligned=True), int64, int64)", 0.08, (
    )),
    ('proxyshade.kernels.random.rand', '(uint64, uint64, int64, int64)', 0.07, (
        ('proxyshade.kernels.random._mix', '(uint64,)'),
    )),
    ('proxyshade.kernels.guide.similarity_sets', "(Array(int32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True), int64, int64, int64, int64, int64)", 2.13, (
        ('proxyshade.kernels.chamfer._label_term', "(Array(uint32, 1, 'C', False, aligned=True), Array(uint32, 1, 'C', False, aligned=True), int64)"),
        ('proxyshade.kernels.chamfer.chamfer_bounded', "(Array(uint32, 1, 'C', False, aligned=True), Array(uint32, 1, 'C', False, aligned=True), int64)"),
        ('proxyshade.kernels.chamfer.chamfer_masks', "(Array(uint32, 1, 'C', False, aligned=True), Array(uint32, 1, 'C', False, aligned=True))"),
        ('proxyshade.kernels.chamfer.dilate', '(int64,)'),
        ('proxyshade.kernels.chamfer.one_way_label', '(int64, int64)'),
        ('proxyshade.kernels.chamfer.popcount25', '(int64,)'),
        ('proxyshade.kernels.guide._clamp', '(int64, Literal[int](0), int64)'),
        ('proxyshade.kernels.guide._color_window', "(Array(float64, 3, 'C', False, aligned=True), int64, int64, int64, Array(float64, 1, 'C', False, aligned=True))"),
        ('proxyshade.kernels.guide._similarity_row', "(int64, Array(uint32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True), int64, int64, int64, int64, int64, Array(int32, 4, 'C', False, aligned=True))"),
        ('proxyshade.kernels.guide._window_dist', "(Literal[int](1), Array(uint32, 1, 'C', False, aligned=True), Array(uint32, 1, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True))"),
        ('proxyshade.kernels.random.rand', '(int64, int64, int64, Literal[int](0))'),
        ('proxyshade.kernels.random.uniform', '(int64, int64, int64, Literal[int](0))'),
    )),
    ('proxyshade.kernels.patch._label_lists', "(Array(int32, 2, 'C', False, aligned=True), int64)", 0.25, (
    )),
    ('proxyshade.kernels.guide._init_state', "(Array(int32, 2, 'C', False, aligned=True), int64, int64, Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), int64)", 0.15, (
    )),
    ('proxyshade.kernels.guide._subpass', "(Array(int32, 3, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), UniTuple(int64, 2), Named('proxyshade.kernels.guide.Exemplar', (Array(int32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True), Array(int32, 4, 'C', False, aligned=True))), Named('proxyshade.kernels.guide.Guide', (Array(uint32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.guide.Rule', (int64, float64, int64, int64)))", 2.17, (
        ('proxyshade.kernels.guide._candidate', "(int64, int64, int64, Array(int32, 3, 'C', False, aligned=True), Array(int32, 4, 'C', False, aligned=True), int64)"),
        ('proxyshade.kernels.guide._color_window', "(Array(float64, 3, 'C', False, aligned=True), int32, int32, int64, Array(float64, 1, 'C', False, aligned=True))"),
        ('proxyshade.kernels.guide._subpass_row', "(int64, int64, Array(int32, 3, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Named('proxyshade.kernels.guide.Exemplar', (Array(int32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True), Array(int32, 4, 'C', False, aligned=True))), Named('proxyshade.kernels.guide.Guide', (Array(uint32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.guide.Rule', (int64, float64, int64, int64)))"),
    )),
    ('proxyshade.kernels.guide.upsample_state', "(Array(int32, 3, 'C', False, aligned=True), int64, int64, int64, int64, int64)", 0.1, (
    )),
    ('proxyshade.kernels.jfa._pass', "(Array(int64, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), int64, float64, Array(int64, 1, 'C', False, aligned=True))", 0.66, (
        ('proxyshade.kernels.jfa._cost', '(int64, int64, int64, int64, int64, int64, float64)'),
    )),
    ('proxyshade.kernels.edit.paste_depth', "(Array(bool, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), int64, int64, int64, Array(float32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True))", 0.31, (
    )),
    ('proxyshade.kernels.edit.paste_unproject', "(Array(bool, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), int64, int64, Array(float64, 2, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))", 0.65, (
    )),
    ('proxyshade.kernels.edit.paste_follow', "(Array(bool, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), int64, int64, Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))", 0.28, (
    )),
    ('proxyshade.kernels.edit.paste_follow', "(Array(bool, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), int64, int64, Array(uint32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True))", 0.29, (
    )),
    ('proxyshade.kernels.features._area_resample_rows', "(Array(float32, 3, 'C', False, aligned=True), int64, int64, float64, Array(float32, 3, 'C', False, aligned=True), int64, int64)", 0.26, (
    )),
    ('proxyshade.kernels.features._mode_resample', "(Array(int32, 2, 'C', False, aligned=True), int64, int64, float64, int64, Array(int32, 2, 'C', False, aligned=True))", 0.32, (
    )),
    ('proxyshade.kernels.distance._contour_mask', "(Array(int32, 2, 'C', False, aligned=True),)", 0.2, (
    )),
    ('proxyshade.kernels.distance._nearest_site_columns', "(Array(bool, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), int64, int64)", 0.35, (
        ('proxyshade.kernels.distance._envelope_1d_arg', "(Array(int64, 1, 'C', False, aligned=True), int64, Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True))"),
    )),
    ('proxyshade.kernels.distance._nearest_site_rows', "(Array(int64, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), int64, int64)", 0.16, (
    )),
    ('proxyshade.kernels.distance._dist_sq', "(Array(int32, 3, 'C', False, aligned=True),)", 0.12, (
    )),
    ('proxyshade.kernels.distance._sqrt_clamped', "(Array(int64, 2, 'C', False, aligned=True), float64, Array(float32, 2, 'C', False, aligned=True))", 0.19, (
    )),
    ('proxyshade.kernels.features._heights', "(Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), int64, int64)", 0.11, (
    )),
    ('proxyshade.kernels.random._keys', '(int64, int64)', 0.12, (
        ('proxyshade.kernels.random.rand', '(int64, int64, Literal[int](0), Literal[int](0))'),
    )),
    ('proxyshade.kernels.patch._mask_hashes', "(Array(uint32, 3, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True))", 0.16, (
        ('proxyshade.kernels.patch._mask_hash', "(Array(uint32, 1, 'C', False, aligned=True),)"),
    )),
    ('proxyshade.kernels.patch._runs', "(Array(uint32, 3, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(uint64, 1, 'C', False, aligned=True))", 0.23, (
    )),
    ('proxyshade.kernels.patch._positions', "(Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), int64)", 0.08, (
    )),
    ('proxyshade.kernels.patch._flood_fill', "(Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), Named('proxyshade.kernels.patch.Cover', (Array(bool, 2, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True))), Array(int64, 1, 'C', False, aligned=True), int64, float64, float64, int64, Array(int64, 1, 'C', False, aligned=True), Named('proxyshade.kernels.patch.Groups', (Array(int64, 1, 'C', False, aligned=True), Array(uint64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(bool, 1, 'C', False, aligned=True))), Array(int64, 1, 'C', False, aligned=True))", 2.49, (
        ('proxyshade.kernels.features.dist_sq_contour', "(Array(float32, 2, 'C', False, aligned=True), Literal[int](1), int64, int64, Array(float32, 1, 'C', False, aligned=True), float64)"),
        ('proxyshade.kernels.features.gather_target', "(Array(float32, 2, 'C', False, aligned=True), int64, int64, Array(float32, 1, 'C', False, aligned=True))"),
        ('proxyshade.kernels.patch._best_by_window', "(Named('proxyshade.kernels.patch.Groups', (Array(int64, 1, 'C', False, aligned=True), Array(uint64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(bool, 1, 'C', False, aligned=True))), int64, int64, Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), Named('proxyshade.kernels.patch.Probe', (Array(float32, 1, 'C', False, aligned=True), Array(uint32, 1, 'C', False, aligned=True), float32)), float64, int64, Named('proxyshade.kernels.patch.Scan', (Array(int64, 1, 'C', False, aligned=True), int64, int64)))"),
        ('proxyshade.kernels.patch._best_match', "(Array(int64, 1, 'C', False, aligned=True), Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), Named('proxyshade.kernels.patch.Probe', (Array(float32, 1, 'C', False, aligned=True), Array(uint32, 1, 'C', False, aligned=True), float32)), float64, int64, Named('proxyshade.kernels.patch.Scan', (Array(int64, 1, 'C', False, aligned=True), int64, int64)), bool)"),
        ('proxyshade.kernels.patch._continued_bound', "(Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), Named('proxyshade.kernels.patch.Cover', (Array(bool, 2, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True))), int64, int64, Named('proxyshade.kernels.patch.Probe', (Array(float32, 1, 'C', False, aligned=True), Array(uint32, 1, 'C', False, aligned=True), float32)), Named('proxyshade.kernels.patch.Scan', (Array(int64, 1, 'C', False, aligned=True), int64, int64)))"),
        ('proxyshade.kernels.patch._eq1', "(Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), int64, int64, Array(float32, 1, 'C', False, aligned=True), Array(uint32, 1, 'C', False, aligned=True), float32, Named('proxyshade.kernels.features.Metric', (float64, float64)), float64)"),
        ('proxyshade.kernels.patch._grow', "(Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), Named('proxyshade.kernels.patch.Cover', (Array(bool, 2, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True))), int64, int64, int64, int64, int64, float64, Array(int64, 1, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True))"),
        ('proxyshade.kernels.random.rand', '(int64, int64, Literal[int](23719), Literal[int](0))'),
    )),
    ('proxyshade.kernels.lookup._bilinear', "(Array(float32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))", 0.67, (
    )),
    ('proxyshade.kernels.features._box_blur_centred', "(Array(float32, 3, 'C', False, aligned=True), int64, Array(float32, 3, 'C', False, aligned=True))", 0.29, (
        ('proxyshade.kernels.features._box_mean_1d', "(Array(float32, 3, 'C', False, aligned=True), int64, int64, int64, int64, Literal[int](0), Literal[int](1))"),
        ('proxyshade.kernels.features._box_mean_1d', "(Array(float32, 3, 'C', False, aligned=True), int64, int64, int64, int64, Literal[int](1), Literal[int](0))"),
    )),
    ('proxyshade.kernels.correct._knn_pass', "(int64, Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), int64, int64, int64, int64, Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Tuple((Array(int32, 3, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True))), Tuple((Array(int32, 3, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True))))", 4.23, (
        ('proxyshade.kernels.correct._ex_dist', "(Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), int64, int64, int64, int64, float64)"),
        ('proxyshade.kernels.correct._insert', "(Array(int32, 1, 'C', False, aligned=True), Array(int32, 1, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), int64, int64, int64, float64)"),
        ('proxyshade.kernels.correct._knn_init', "(Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), int64, int64, int64, Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Tuple((Array(int32, 3, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True))), int64, int64)"),
        ('proxyshade.kernels.correct._knn_iter', "(Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), int64, int64, int64, int64, Tuple((Array(int32, 3, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True))), Tuple((Array(int32, 3, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True))), int64, int64)"),
        ('proxyshade.kernels.correct._knn_rescore', "(Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), int64, int64, Tuple((Array(int32, 3, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True))), int64, int64)"),
        ('proxyshade.kernels.random.rand', '(int64, int64, int64, int64)'),
    )),
    ('proxyshade.kernels.correct._downsample', "(Array(int32, 3, 'C', False, aligned=True), int64, int64, int64, int64, int64, Array(int32, 3, 'C', False, aligned=True))", 0.1, (
    )),
    ('proxyshade.kernels.correct._usage_excess', "(Array(int32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), int64, Array(float64, 2, 'C', False, aligned=True))", 0.48, (
    )),
    ('proxyshade.kernels.correct._tone_balance', "(Array(int32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), int64, int64, Array(float64, 2, 'C', False, aligned=True))", 0.23, (
    )),
    ('proxyshade.kernels.correct._subpass', "(Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), Named('proxyshade.kernels.correct.Rule', (int64, bool, float64, float64, float64)), Array(int32, 4, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), UniTuple(int64, 2), Array(int64, 2, 'C', False, aligned=True), Tuple((Array(float64, 1, 'C', False, aligned=True), int64, Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True))))", 2.88, (
        ('proxyshade.kernels.correct._cand_dist', "(Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), bool, int64, int64, int64, int64, Array(float32, 1, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), float64)"),
        ('proxyshade.kernels.correct._subpass_rows', "(Named('proxyshade.kernels.features.Level', (int64, Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Named('proxyshade.kernels.features.Metric', (float64, float64)), Named('proxyshade.kernels.correct.Rule', (int64, bool, float64, float64, float64)), Array(int32, 4, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(int32, 3, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), UniTuple(int64, 2), Array(int64, 2, 'C', False, aligned=True), int64, int64, Tuple((Array(float64, 1, 'C', False, aligned=True), int64, Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True))))"),
        ('proxyshade.kernels.correct.far_copy', "(Array(int32, 3, 'C', False, aligned=True), int64, int64, int64, int64, int64, float64, int64, Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), int64)"),
        ('proxyshade.kernels.correct.rejected', "(Array(int32, 3, 'C', False, aligned=True), int64, int64, int64, int64, int64, int64)"),
        ('proxyshade.kernels.features.dist_sq_contour', "(Array(float32, 2, 'C', False, aligned=True), int64, int64, int64, Array(float32, 1, 'C', False, aligned=True), float64)"),
        ('proxyshade.kernels.features.dist_sq_rgb', "(Array(float32, 3, 'C', False, aligned=True), int64, int64, int64, Array(float32, 2, 'C', False, aligned=True), float64)"),
    )),
    ('proxyshade.kernels.correct._upsample', "(Array(int32, 3, 'C', False, aligned=True), int64, int64, int64, int64, int64, Array(int32, 3, 'C', False, aligned=True))", 0.1, (
    )),
    ('proxyshade.kernels.magnify._label_ok', "(Array(int32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True))", 0.43, (
    )),
    ('proxyshade.kernels.magnify._front_steps', "(Array(int32, 3, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), int64)", 0.73, (
    )),
    ('proxyshade.kernels.patch._offset_components', "(Array(int64, 3, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True))", 0.36, (
    )),
    ('proxyshade.kernels.magnify._magnify', "(Array(int32, 3, 'C', False, aligned=True), int64, int64, int64, Array(int32, 3, 'C', False, aligned=True))", 0.28, (
    )),
    ('proxyshade.kernels.seams._sub_pass', "(Array(int32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', True, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), int64, Array(uint8, 2, 'C', False, aligned=True), Array(uint8, 2, 'C', False, aligned=True), Array(uint8, 2, 'C', False, aligned=True), int64, Array(int64, 1, 'C', False, aligned=True))", 2.14, (
        ('proxyshade.kernels.seams._dist2', "(Array(float32, 3, 'C', True, aligned=True), int64, int64, int64, int64)"),
        ('proxyshade.kernels.seams._energy', "(Array(int32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', True, aligned=True), Array(int32, 2, 'C', False, aligned=True), int64, int64, int64, int64)"),
        ('proxyshade.kernels.seams._pair_at', "(Array(int32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', True, aligned=True), Array(int32, 2, 'C', False, aligned=True), int64, int64, int64, int64, int64, int64)"),
    )),
    ('proxyshade.kernels.seams._run_pass', "(Array(int32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', True, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), bool, int64, Array(uint8, 2, 'C', False, aligned=True), Array(uint8, 3, 'C', False, aligned=True), Array(uint8, 3, 'C', False, aligned=True), Array(uint8, 2, 'C', False, aligned=True), int64, Array(int64, 1, 'C', False, aligned=True))", 2.22, (
        ('proxyshade.kernels.seams._on_run', "(Array(int32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), int32, int64, int64, int64, int64, int64, int64, int64, int64)"),
        ('proxyshade.kernels.seams._run_at', "(Array(int32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', True, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), int64, int64, int64, Array(float64, 1, 'C', False, aligned=True), Array(bool, 1, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), Array(uint8, 2, 'C', False, aligned=True), Array(uint8, 3, 'C', False, aligned=True), Array(uint8, 3, 'C', False, aligned=True), int64)"),
        ('proxyshade.kernels.seams._run_line', "(Array(int32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', True, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), bool, int64, Array(uint8, 2, 'C', False, aligned=True), Array(uint8, 3, 'C', False, aligned=True), Array(uint8, 3, 'C', False, aligned=True), Array(uint8, 2, 'C', False, aligned=True), int64, Array(int64, 1, 'C', False, aligned=True))"),
    )),
    ('proxyshade.kernels.seams._shift_passes', "(Array(int32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', True, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), int64, int64, int64, float64)", 3.08, (
        ('proxyshade.kernels.seams._spread', "(Array(float32, 3, 'C', True, aligned=True), float64, Array(int32, 2, 'C', False, aligned=True), int64, int64, int64, int64)"),
    )),
    ('proxyshade.kernels.poisson._rhs', "(Array(float32, 3, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))", 0.74, (
    )),
    ('proxyshade.kernels.stencil.fine_operator', "(Array(bool, 2, 'C', False, aligned=True), float32)", 0.29, (
    )),
    ('proxyshade.kernels.multigrid._coarsen', "(Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), float32)", 0.31, (
        ('proxyshade.kernels.stencil.edge', "(Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), int64, int64, int64, int64)"),
    )),
    ('proxyshade.kernels.multigrid._residual', "(Array(float32, 2, 'C', False, aligned=True), none, none, Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))", 0.58, (
        ('proxyshade.kernels.stencil.edge', "(Array(float32, 2, 'C', False, aligned=True), none, int64, int64, int64, int64)"),
    )),
    ('proxyshade.kernels.multigrid._dot3', "(Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True))", 0.87, (
    )),
    ('proxyshade.kernels.multigrid._jacobi_start', "(Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), int64)", 0.3, (
    )),
    ('proxyshade.kernels.multigrid._smooth', "(Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), int64)", 0.59, (
    )),
    ('proxyshade.kernels.multigrid._residual_restrict', "(Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))", 1.04, (
    )),
    ('proxyshade.kernels.multigrid._vcycle_serial', "(Array(float32, 1, 'C', False, aligned=True), Array(float32, 1, 'C', False, aligned=True), Array(float32, 1, 'C', False, aligned=True), Array(float32, 1, 'C', False, aligned=True), Array(float32, 1, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), int64, int64)", 2.64, (
        ('proxyshade.kernels.multigrid._coarse_solve', "(Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), int64)"),
        ('proxyshade.kernels.multigrid._jacobi_start_serial', "(Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), int64)"),
        ('proxyshade.kernels.multigrid._prolong_add_serial', "(Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), float64)"),
        ('proxyshade.kernels.multigrid._residual_restrict_serial', "(Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))"),
        ('proxyshade.kernels.multigrid._smooth_serial', "(Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), int64)"),
    )),
    ('proxyshade.kernels.multigrid._prolong_add', "(Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), float64)", 0.29, (
    )),
    ('proxyshade.kernels.multigrid._matvec_dot', "(Array(float32, 2, 'C', False, aligned=True), none, none, Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True))", 0.95, (
    )),
    ('proxyshade.kernels.multigrid._cg_update', "(Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True))", 1.09, (
    )),
    ('proxyshade.kernels.multigrid._xpby3', "(Array(float32, 3, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))", 0.3, (
    )),
    ('proxyshade.kernels.shadow._pcf', "(Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), int64, float64, Array(float64, 2, 'C', False, aligned=True))", 0.57, (
        ('proxyshade.kernels.shadow._occluded', "(Array(float64, 2, 'C', False, aligned=True), int64, int64, float64, float64)"),
    )),
    ('proxyshade.kernels.reproject._inverse_depth', "(Array(float32, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True))", 0.23, (
    )),
    ('proxyshade.kernels.reproject.grid_corners', "(Array(float64, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), float64)", 3.57, (
        ('proxyshade.kernels.reproject._connected', "(Array(float64, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), int64, int64, int64, int64, float64)"),
        ('proxyshade.kernels.reproject._links', "(Array(float64, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), float64)"),
        ('proxyshade.kernels.reproject.same_surface', '(float64, float64, float64)'),
    )),
    ('proxyshade.kernels.reproject._quad_rows', "(Array(float64, 3, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), float64, int64, int64, float64)", 2.74, (
        ('proxyshade.kernels.reproject._quad', "(Array(float64, 3, 'C', False, aligned=True), int64, int64, Array(float64, 2, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), float64, Array(float64, 2, 'C', False, aligned=True))"),
        ('proxyshade.kernels.reproject._quad', "(Array(float64, 3, 'C', False, aligned=True), uint64, int64, Array(float64, 2, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), float64, Array(float64, 2, 'C', False, aligned=True))"),
        ('proxyshade.kernels.reproject._quad_after', "(Array(float64, 3, 'C', False, aligned=True), int64, int64, Array(float64, 2, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), float64, Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True))"),
        ('proxyshade.kernels.reproject._quad_after', "(Array(float64, 3, 'C', False, aligned=True), uint64, int64, Array(float64, 2, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), float64, Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True))"),
    )),
    ('proxyshade.kernels.raster._bin_count', "(Array(int32, 1, 'C', False, aligned=True), Array(int32, 1, 'C', False, aligned=True), int64, Array(int64, 2, 'C', False, aligned=True))", 0.32, (
    )),
    ('proxyshade.kernels.raster._bin_fill', "(Array(int32, 1, 'C', False, aligned=True), Array(int32, 1, 'C', False, aligned=True), int64, Array(int64, 2, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True))", 0.35, (
    )),
    ('proxyshade.kernels.reproject._splat_bands', "(Array(float64, 3, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), float64, int64, int64, int64, Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True))", 1.5, (
        ('proxyshade.kernels.reproject._edge', '(float64, float64, float64, float64, float64, float64)'),
        ('proxyshade.kernels.reproject._tri_area', "(Array(float64, 2, 'C', False, aligned=True), Literal[int](0), Literal[int](1), Literal[int](3), float64, float64, float64)"),
        ('proxyshade.kernels.reproject._tri_area', "(Array(float64, 2, 'C', False, aligned=True), Literal[int](0), Literal[int](3), Literal[int](2), float64, float64, float64)"),
    )),
    ('proxyshade.kernels.reproject._stale', "(Array(float64, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), float64, int64, int64, Array(bool, 2, 'C', False, aligned=True))", 0.43, (
    )),
    ('proxyshade.kernels.reproject.classify', "(Array(int64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), float64)", 1.13, (
    )),
    ('proxyshade.kernels.layout._luma_encoded', "(Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))", 0.35, (
    )),
    ('proxyshade.kernels.layout._profile', "(Array(float32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), int64, int64, Array(float64, 3, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True))", 0.11, (
    )),
    ('proxyshade.kernels.layout._at_height', "(Array(float64, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))", 0.69, (
    )),
    ('proxyshade.kernels.layout._block_sums', "(Array(float32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), int64, int64, Array(float64, 4, 'C', False, aligned=True))", 0.09, (
    )),
    ('proxyshade.kernels.layout._box_blocks', "(Array(float64, 4, 'C', False, aligned=True), int64)", 0.26, (
    )),
    ('proxyshade.kernels.layout._spread', "(Array(float64, 4, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), int64, Array(float32, 3, 'C', False, aligned=True))", 0.48, (
    )),
    ('proxyshade.kernels.layout._move_luma_chroma', "(Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))", 0.42, (
    )),
    ('proxyshade.kernels.layout._cctf_image', "(Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), bool)", 0.34, (
    )),
    ('proxyshade.kernels.grain._boxes', "(Array(int32, 2, 'C', False, aligned=True), int64)", 0.12, (
    )),
    ('proxyshade.kernels.grain._sat', "(Array(float32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), int64, int64, int64, int64, int64, int64, Array(float64, 3, 'C', False, aligned=True))", 1.17, (
    )),
    ('proxyshade.kernels.grain._label_pass', "(Array(float32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), int64, int64, int64, Array(float64, 3, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), bool)", 1.09, (
    )),
    ('proxyshade.kernels.grain._block_means', "(Array(float64, 3, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(float64, 4, 'C', False, aligned=True))", 0.38, (
    )),
    ('proxyshade.kernels.grain._block_bins', "(Array(int32, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), int64, int64, int64, int64, int64, int64, Array(int64, 3, 'C', False, aligned=True))", 0.34, (
    )),
    ('proxyshade.kernels.grain._block_energy', "(Array(float64, 4, 'C', False, aligned=True), Array(int64, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True))", 0.34, (
    )),
    ('proxyshade.kernels.grain._spread_pass', "(Array(float32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), int64, int64, int64, int64, int64, int64, Array(float64, 3, 'C', False, aligned=True), Array(float64, 4, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True), Array(float64, 4, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))", 1.64, (
    )),
    ('proxyshade.kernels.reproject.transfer', "(Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True), float64)", 0.87, (
    )),
    ('proxyshade.kernels.lookup._lanczos_rgb', "(Array(float32, 3, 'C', False, aligned=True), Array(float64, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), bool, Array(float32, 3, 'C', False, aligned=True))", 2.08, (
        ('proxyshade.kernels.lookup._tap_start', '(float64, int64, int64, int64)'),
    )),
    ('proxyshade.kernels.reproject.gather_prev_planes', "(Tuple((Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True))), Array(uint32, 2, 'C', False, aligned=True), Tuple((Array(float64, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), float64, float64, Array(bool, 2, 'C', False, aligned=True), int64)", 1.25, (
    )),
    ('proxyshade.kernels.reproject.uniform_windows', "(Array(uint32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), int64, int64)", 1.55, (
    )),
    ('proxyshade.kernels.reproject.sharpen_residual', "(Tuple((Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True))), Array(bool, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))", 1.04, (
    )),
    ('proxyshade.kernels.reproject.first_positions', "(Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), float64, float64)", 1.33, (
    )),
    ('proxyshade.kernels.reproject.anchor_seams', "(Tuple((Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True))), Array(bool, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Tuple((Array(float64, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Tuple((Array(bool, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True))), float64, float64, float64, Tuple((Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))))", 1.14, (
    )),
    ('proxyshade.kernels.reproject.fill_from_neighbours_into', "(Array(bool, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Named('proxyshade.kernels.reproject.Carried', (Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), int64, float64, Named('proxyshade.kernels.reproject.Carried', (Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True))), Array(uint32, 2, 'C', False, aligned=True))", 1.82, (
    )),
    ('proxyshade.kernels.temporal.continue_filled', "(Array(bool, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), float64)", 0.47, (
    )),
    ('proxyshade.kernels.temporal.map_deviation_patches', "(Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), float64)", 1.06, (
    )),
    ('proxyshade.kernels.temporal.patch_mean', "(Array(bool, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), int64)", 0.11, (
    )),
    ('proxyshade.kernels.random.uniform_field', "(int64, Array(uint32, 2, 'C', False, aligned=True))", 0.37, (
        ('proxyshade.kernels.random.rand', '(int64, uint32, Literal[int](0), Literal[int](0))'),
        ('proxyshade.kernels.random.uniform', '(int64, uint32, Literal[int](0), Literal[int](0))'),
    )),
    ('proxyshade.kernels.temporal.in_ids', "(Array(bool, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(bool, 1, 'C', False, aligned=True))", 0.49, (
    )),
    ('proxyshade.kernels.temporal.area_perimeter', "(Array(bool, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), int64)", 0.13, (
    )),
    ('proxyshade.kernels.temporal.fits_label', "(Array(uint32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True))", 0.62, (
    )),
    ('proxyshade.kernels.temporal._label_gradients', "(Array(float32, 3, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), int64, Array(float64, 1, 'C', True, aligned=True))", 2.19, (
    )),
    ('proxyshade.kernels.temporal.flag_reasons', "(Array(bool, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), float64, Array(uint32, 2, 'C', False, aligned=True), uint32, Tuple((Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True))), Array(uint32, 2, 'C', False, aligned=True), UniTuple(uint32, 4))", 2.19, (
    )),
    ('proxyshade.kernels.temporal.clean_flags', "(Array(uint32, 2, 'C', False, aligned=True), int64, int64, int64, Array(bool, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), int64, int64, int64)", 2.22, (
    )),
    ('proxyshade.kernels.temporal.keep_carried', "(Array(uint32, 2, 'C', False, aligned=True), int64, Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), bool)", 1.32, (
    )),
    ('proxyshade.kernels.correct._block_any', "(Array(bool, 2, 'C', False, aligned=True), int64, Array(bool, 2, 'C', False, aligned=True))", 0.08, (
    )),
    ('proxyshade.kernels.magnify._only_target', "(Array(int32, 3, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(int32, 2, 'C', False, aligned=True))", 0.36, (
    )),
    ('proxyshade.kernels.temporal.merge_redo', "(Array(bool, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), uint32, Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True))", 0.72, (
    )),
    ('proxyshade.kernels.lookup._lanczos_rgb', "(Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float64, 2, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), bool, Array(float32, 3, 'C', False, aligned=True))", 1.47, (
    )),
    ('proxyshade.kernels.temporal.components4', "(Array(bool, 2, 'C', False, aligned=True),)", 2.59, (
    )),
    ('proxyshade.kernels.temporal.area_perimeter', "(Array(bool, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), int64)", 0.12, (
    )),
    ('proxyshade.kernels.sor._dense_ranks', "(Array(int64, 1, 'C', False, aligned=True),)", 0.12, (
    )),
    ('proxyshade.kernels.sor._group_order', "(Array(int64, 1, 'C', False, aligned=True), int64)", 0.1, (
    )),
    ('proxyshade.kernels.sor._list_neighbours', "(Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), int64, int64)", 0.22, (
    )),
    ('proxyshade.kernels.sor._seam_edges', "(Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), float32)", 0.27, (
    )),
    ('proxyshade.kernels.sor._rhs_at', "(Array(float32, 3, 'C', False, aligned=True), Array(uint32, 2, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), Array(int64, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), float32, Array(float32, 2, 'C', False, aligned=True), Array(float32, 1, 'C', False, aligned=True))", 0.61, (
    )),
    ('proxyshade.kernels.sor._sor_regions', "(Named('proxyshade.kernels.sor.Regions', (Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True), Array(int64, 1, 'C', False, aligned=True))), Named('proxyshade.kernels.sor.ListedSystem', (Array(int64, 2, 'C', False, aligned=True), Array(float32, 1, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True))), Array(float32, 2, 'C', False, aligned=True), float64, int64, int64, Array(int64, 1, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True))", 1.52, (
        ('proxyshade.kernels.sor._run_residual', "(Array(int64, 2, 'C', False, aligned=True), Array(float32, 1, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), int64, int64, Array(float32, 2, 'C', False, aligned=True), Array(float64, 1, 'C', False, aligned=True))"),
    )),
    ('proxyshade.kernels.temporal.colour_planes', "(Array(float32, 3, 'C', False, aligned=True), Array(bool, 2, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), Array(float32, 2, 'C', False, aligned=True), bool)", 0.93, (
    )),
    ('proxyshade.kernels.cryptomatte._rank', "(Array(uint32, 2, 'C', False, aligned=True), int64, Array(float32, 1, 'C', False, aligned=True), int64, Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))", 1.12, (
        ('proxyshade.kernels.cryptomatte._rank_row', "(int64, Array(uint32, 2, 'C', False, aligned=True), int64, Array(float32, 1, 'C', False, aligned=True), int64, Array(float32, 3, 'C', False, aligned=True), Array(float32, 3, 'C', False, aligned=True))"),
    )),
]
CALLERS = {
    0: 'ProxyRender',
    1: 'ProxyRender',
    2: 'ProxyRender',
    3: 'ProxyRender',
    4: 'GuideSynth',
    5: 'GuideSynth',
    6: 'GuideSynth',
    7: 'GuideSynth',
    8: 'GuideSynth',
    9: 'GuideSynth',
    10: 'GuideSynth',
    11: 'GuideSynth',
    12: 'GuideSynth',
    13: 'GuideSynth',
    14: 'DepthExtend',
    15: 'DepthExtend',
    16: 'DepthExtend',
    17: 'DepthExtend',
    18: 'DepthExtend',
    19: 'PatchInit',
    20: 'PatchInit',
    21: 'PatchInit',
    22: 'PatchInit',
    23: 'PatchInit',
    24: 'PatchInit',
    25: 'PatchInit',
    26: 'PatchInit',
    27: 'PatchInit',
    28: 'PatchInit',
    29: 'PatchInit',
    30: 'PatchInit',
    31: 'PatchInit',
    32: 'PatchInit',
    33: 'Correct',
    34: 'Correct',
    35: 'Correct',
    36: 'Correct',
    37: 'Correct',
    38: 'Correct',
    39: 'Correct',
    40: 'Correct',
    41: 'Correct',
    42: 'Correct',
    43: 'Magnify',
    44: 'Magnify',
    45: 'Magnify',
    46: 'Magnify',
    47: 'Poisson',
    48: 'Poisson',
    49: 'Poisson',
    50: 'Poisson',
    51: 'Poisson',
    52: 'Poisson',
    53: 'Poisson',
    54: 'Poisson',
    55: 'Poisson',
    56: 'Poisson',
    57: 'Poisson',
    58: 'Poisson',
    59: 'Poisson',
    60: 'ShadowMap',
    61: 'ConsistentDepth',
    62: 'ConsistentDepth',
    63: 'ConsistentDepth',
    64: 'ConsistentDepth',
    65: 'ConsistentDepth',
    66: 'ConsistentDepth',
    67: 'ConsistentDepth',
    68: 'ConsistentDepth',
    69: 'Poisson',
    70: 'Poisson',
    71: 'Poisson',
    72: 'Poisson',
    73: 'Poisson',
    74: 'Poisson',
    75: 'Poisson',
    76: 'Poisson',
    77: 'Poisson',
    78: 'Poisson',
    79: 'Poisson',
    80: 'Poisson',
    81: 'Poisson',
    82: 'Poisson',
    83: 'Poisson',
    84: 'Reproject',
    85: 'Reproject',
    86: 'Reproject',
    87: 'Reproject',
    88: 'Reproject',
    89: 'Reproject',
    90: 'Reproject',
    91: 'Reproject',
    92: 'Reproject',
    93: 'Reproject',
    94: 'Reproject',
    95: 'Reproject',
    96: 'Reproject',
    97: 'Reproject',
    98: 'Reproject',
    99: 'Reproject',
    100: 'Reproject',
    101: 'Reproject',
    102: 'Reproject',
    103: 'Resynthesize',
    104: 'Resynthesize',
    105: 'Resynthesize',
    106: 'Resynthesize',
    107: 'Resynthesize',
    108: 'Resynthesize',
    109: 'Resynthesize',
    110: 'Resynthesize',
    111: 'Resynthesize',
    112: 'Resynthesize',
    113: 'Resynthesize',
    114: 'Resynthesize',
    115: 'Resynthesize',
    116: 'Cryptomatte',
}
VARIANTS = {
    0: 'f117c8810bdb',
    1: 'f117c8810bdb',
    2: 'f117c8810bdb',
    3: 'f117c8810bdb',
    4: 'e9286a0fc774',
    5: 'e9286a0fc774',
    6: 'e9286a0fc774',
    7: 'e9286a0fc774',
    8: 'e9286a0fc774',
    9: 'e9286a0fc774',
    10: 'e9286a0fc774',
    11: 'e9286a0fc774',
    12: 'e9286a0fc774',
    13: 'e9286a0fc774',
    14: '4d55102248fa',
    15: '4d55102248fa',
    16: '4d55102248fa',
    17: '4d55102248fa',
    18: '4d55102248fa',
    19: '610c6cd7c65f',
    20: '610c6cd7c65f',
    21: '610c6cd7c65f',
    22: '610c6cd7c65f',
    23: '610c6cd7c65f',
    24: '610c6cd7c65f',
    25: '610c6cd7c65f',
    26: '610c6cd7c65f',
    27: '610c6cd7c65f',
    28: '610c6cd7c65f',
    29: '610c6cd7c65f',
    30: '610c6cd7c65f',
    31: '610c6cd7c65f',
    32: '610c6cd7c65f',
    33: 'c03d934c88f1',
    34: 'c03d934c88f1',
    35: 'c03d934c88f1',
    36: 'c03d934c88f1',
    37: 'c03d934c88f1',
    38: 'c03d934c88f1',
    39: 'c03d934c88f1',
    40: 'c03d934c88f1',
    41: 'c03d934c88f1',
    42: 'c03d934c88f1',
    43: 'eba29e2d97b6',
    44: 'eba29e2d97b6',
    45: 'eba29e2d97b6',
    46: 'eba29e2d97b6',
    47: 'ca2ac93537db',
    48: 'ca2ac93537db',
    49: 'ca2ac93537db',
    50: 'ca2ac93537db',
    51: 'ca2ac93537db',
    52: 'ca2ac93537db',
    53: 'ca2ac93537db',
    54: 'ca2ac93537db',
    55: 'ca2ac93537db',
    56: 'ca2ac93537db',
    57: 'ca2ac93537db',
    58: 'ca2ac93537db',
    59: 'ca2ac93537db',
    60: '5024ea2ae74b',
    61: '2d6d3b9210c8',
    62: '2d6d3b9210c8',
    63: '2d6d3b9210c8',
    64: '2d6d3b9210c8',
    65: '2d6d3b9210c8',
    66: '2d6d3b9210c8',
    67: '2d6d3b9210c8',
    68: '2d6d3b9210c8',
    69: '260063618204',
    70: '260063618204',
    71: '260063618204',
    72: '260063618204',
    73: '260063618204',
    74: '260063618204',
    75: '260063618204',
    76: '260063618204',
    77: '260063618204',
    78: '260063618204',
    79: '260063618204',
    80: '260063618204',
    81: '260063618204',
    82: '260063618204',
    83: '260063618204',
    84: 'd8ed107f8680',
    85: 'd8ed107f8680',
    86: 'd8ed107f8680',
    87: 'd8ed107f8680',
    88: 'd8ed107f8680',
    89: 'd8ed107f8680',
    90: 'd8ed107f8680',
    91: 'd8ed107f8680',
    92: 'd8ed107f8680',
    93: 'd8ed107f8680',
    94: 'd8ed107f8680',
    95: 'd8ed107f8680',
    96: 'd8ed107f8680',
    97: 'd8ed107f8680',
    98: 'd8ed107f8680',
    99: 'd8ed107f8680',
    100: 'd8ed107f8680',
    101: 'd8ed107f8680',
    102: 'd8ed107f8680',
    103: '0d6c8a5e840b',
    104: '0d6c8a5e840b',
    105: '0d6c8a5e840b',
    106: '0d6c8a5e840b',
    107: '0d6c8a5e840b',
    108: '0d6c8a5e840b',
    109: '0d6c8a5e840b',
    110: '0d6c8a5e840b',
    111: '0d6c8a5e840b',
    112: '0d6c8a5e840b',
    113: '0d6c8a5e840b',
    114: '0d6c8a5e840b',
    115: '0d6c8a5e840b',
}
