"""GN-FR model: the Point Sampler's attention math, fused vs reference paths, renderer."""

from __future__ import annotations

import pytest
import torch

from gnfr.geometry import image_pixels, pixel_rays
from gnfr.model import GNFR, GNFRConfig
from gnfr.renderer import SourceViews, forward_rays, render_rays
from gnfr.transformer import attention_mask, vector_attention

TINY = GNFRConfig(enc_widths=(8, 16, 16), enc_blocks=(1, 1, 1), feat_ch=8, width=16, depth=2)


def _weights(attend: torch.Tensor) -> torch.Tensor:
    """Attention weights [R, S, V, C] of vector_attention for random inputs."""
    R, S, V = attend.shape
    C = 8
    captured = {}

    def fc(x):
        captured["logits"] = x
        return x

    q, k, pos = torch.randn(R, S, C), torch.randn(R, S, V, C), torch.randn(R, S, V, C)
    v = torch.zeros(R, S, V, C)
    vector_attention(q, k, v, pos, attend, fc)
    logits = captured["logits"].masked_fill(~attend[..., None], float("-inf"))
    return torch.softmax(logits, dim=2)


def test_point_sampler_zeroes_flared_views_and_renormalises():
    g = torch.Generator().manual_seed(0)
    valid = torch.rand(6, 5, 4, generator=g) > 0.2
    flared = torch.rand(6, 5, 4, generator=g) > 0.6
    valid[0, 0] = True
    flared[0, 0] = torch.tensor([True, False, True, False])
    attend, all_flared = attention_mask(valid, flared)
    w = _weights(attend)
    # through the real function: weight of the output equals sum over attended views only
    assert torch.all(w[0, 0, [0, 2]] == 0)
    assert torch.allclose(w.sum(2), torch.ones(6, 5, 8))
    clean = valid & ~flared
    has_clean = clean.any(-1)
    assert torch.all(w[has_clean][~clean[has_clean]] == 0)
    assert torch.equal(all_flared, valid.any(-1) & ~has_clean)


def test_all_flared_point_falls_back_to_validity_and_is_counted():
    valid = torch.tensor([[[True, True, False]], [[False, False, False]]])
    flared = torch.tensor([[[True, True, False]], [[True, False, False]]])
    attend, all_flared = attention_mask(valid, flared)
    assert attend[0, 0].tolist() == [True, True, False]  # validity-only fallback
    assert all_flared.tolist() == [[True], [False]]  # counted; invisible point is not
    assert attend[1, 0].tolist() == [True, True, True]  # valid nowhere: uniform (GNT)
    w = _weights(attend)
    assert torch.all(w[0, 0, 2] == 0) and torch.allclose(w.sum(2), torch.ones(2, 1, 8))


def test_darkest_fallback_keeps_the_darker_half_of_the_views_that_see_an_all_flared_point():
    # point 0: on flare in its 3 valid views (view 3 does not see it): the darker 2 of them
    # are attended; point 1 has a clean view and attends it alone, whatever the colours;
    # point 2: flared in its one valid view, which is kept; point 3 is valid nowhere
    valid = torch.tensor([[True, True, True, False], [True, True, False, False],
                          [False, True, False, False], [False] * 4])[:, None]
    flared = torch.tensor([[True, True, True, False], [True, False, True, True],
                           [True, True, True, True], [True] * 4])[:, None]
    lum = torch.tensor([[0.9, 0.2, 0.5, 0.0], [0.1, 0.8, 0.0, 0.0],
                        [0.0, 0.7, 0.0, 0.0], [0.3, 0.2, 0.1, 0.0]])
    rgb = lum[:, None, :, None].expand(4, 1, 4, 3)
    attend, all_flared = attention_mask(valid, flared, rgb, fallback="darkest")
    assert attend[:, 0].tolist() == [[False, True, True, False], [False, True, False, False],
                                     [False, True, False, False], [True] * 4]
    assert all_flared[:, 0].tolist() == [True, False, True, False]
    # the validity fallback keeps all three; clean points are the same under both rules
    plain, _ = attention_mask(valid, flared)
    assert plain[0, 0].tolist() == [True, True, True, False]
    assert torch.equal(plain[1:3], attend[1:3])
    with pytest.raises(ValueError, match="colours"):
        attention_mask(valid, flared, None, fallback="darkest")
    with pytest.raises(ValueError, match="fallback"):
        attention_mask(valid, flared, rgb, fallback="brightest")


def test_render_config_flare_fallbacks_are_the_model_s():
    from gnfr.transformer import FLARE_FALLBACKS
    from pipeline.render.config import FLARE_FALLBACKS as RENDER_FALLBACKS

    assert RENDER_FALLBACKS == FLARE_FALLBACKS


def test_vector_attention_output_ignores_flagged_views():
    R, S, V, C = 3, 4, 5, 8
    q, k, v, pos = torch.randn(R, S, C), torch.randn(R, S, V, C), torch.randn(R, S, V, C), \
        torch.randn(R, S, V, C)
    attend = torch.ones(R, S, V, dtype=torch.bool)
    attend[..., 1] = False
    fc = torch.nn.Linear(C, C)
    out = vector_attention(q, k, v, pos, attend, fc)
    k2, v2 = k.clone(), v.clone()
    k2[..., 1, :] += 100.0
    v2[..., 1, :] -= 50.0
    assert torch.allclose(out, vector_attention(q, k2, v2, pos, attend, fc), atol=1e-5)


def _scene(V=4, H=40, W=56, seed=0):
    g = torch.Generator().manual_seed(seed)
    K = torch.tensor([[50.0, 0, W / 2], [0, 50.0, H / 2], [0, 0, 1]]).expand(V, 3, 3)
    c2w = torch.eye(4).repeat(V, 1, 1)
    c2w[:, 0, 3] = torch.linspace(-0.3, 0.3, V)
    c2w[:, 2, 3] = -2.0
    imgs = torch.rand(V, 3, H, W, generator=g)
    masks = (torch.rand(V, 1, H, W, generator=g) > 0.7).float()
    return imgs, K, c2w, masks


def test_fused_and_reference_paths_agree_forward_and_backward():
    torch.manual_seed(0)
    model = GNFR(TINY).eval()
    imgs, K, c2w, masks = _scene()
    o, d = pixel_rays(K[0], c2w[0], image_pixels(40, 56)[::37])
    t = torch.linspace(1.0, 3.0, 12).expand(o.shape[0], 12)
    grads = []
    for ref in (False, True):
        model.zero_grad()
        src = SourceViews.encode(model, imgs, K, c2w, masks, "cpu", grad=True)
        out = forward_rays(model, src, torch.arange(1, 4), o, d, t, reference=ref)
        (out["rgb"].square().sum() + out["depth"].sum()).backward()
        grads.append((out, [p.grad.clone() for p in model.parameters()]))
    (a, ga), (b, gb) = grads
    assert torch.allclose(a["rgb"], b["rgb"], atol=1e-5)
    assert torch.allclose(a["depth"], b["depth"], atol=1e-5)
    for x, y in zip(ga, gb, strict=True):
        assert torch.allclose(x, y, atol=1e-4, rtol=1e-3)


def test_render_rays_is_deterministic_chunk_independent_and_flags_flare():
    torch.manual_seed(0)
    model = GNFR(TINY)
    imgs, K, c2w, masks = _scene()
    src = SourceViews.encode(model, imgs, K, c2w, masks, "cpu", chunk=2)
    o, d = pixel_rays(K[0], c2w[0], image_pixels(40, 56)[:200])
    near, far = torch.full((200,), 1.0), torch.full((200,), 3.0)
    a = render_rays(model, src, torch.arange(1, 4), o, d, near, far, 16, chunk=64)
    b = render_rays(model, src, torch.arange(1, 4), o, d, near, far, 16, chunk=200)
    assert a["rgb"].shape == (200, 3) and a["depth"].shape == (200,)
    assert torch.allclose(a["rgb"], b["rgb"], atol=1e-5)
    assert bool(((a["depth"] >= 1.0) & (a["depth"] <= 3.0)).all())
    nd = render_rays(model, src, torch.arange(1, 4), o, d, near, far, 16, with_depth=False)
    assert "depth" not in nd and torch.allclose(nd["rgb"], a["rgb"], atol=1e-5)
    full = SourceViews.encode(model, imgs, K, c2w, torch.ones_like(masks), "cpu")
    c = render_rays(model, full, torch.arange(1, 4), o, d, near, far, 16)
    assert float(c["all_flared"].mean()) > 0.5 and float(a["all_flared"].mean()) < 0.5
    off = render_rays(model, full, torch.arange(1, 4), o, d, near, far, 16,
                      point_sampler=False)
    assert float(off["all_flared"].max()) == 0.0
    # with every view flared, the fallback equals rendering with the Point Sampler off
    assert torch.allclose(c["rgb"][c["all_flared"] == 1], off["rgb"][c["all_flared"] == 1],
                          atol=1e-5)


def test_padded_chunks_give_the_same_rays_in_one_shape():
    """``pad``: 200 rays in chunks of 64 run as four 64-ray passes (the last padded) and
    give the unpadded result, trimmed to the 200 rays."""
    torch.manual_seed(0)
    model = GNFR(TINY)
    imgs, K, c2w, masks = _scene()
    src = SourceViews.encode(model, imgs, K, c2w, masks, "cpu")
    o, d = pixel_rays(K[0], c2w[0], image_pixels(40, 56)[:200])
    near, far = torch.full((200,), 1.0), torch.full((200,), 3.0)
    shapes = []
    hook = model.register_forward_hook(lambda m, args, out: shapes.append(args[0].shape[0]))
    a = render_rays(model, src, torch.arange(1, 4), o, d, near, far, 16, chunk=64, pad=True)
    hook.remove()
    b = render_rays(model, src, torch.arange(1, 4), o, d, near, far, 16, chunk=64)
    assert shapes == [64, 64, 64, 64]
    assert a["rgb"].shape == (200, 3) and a["all_flared"].shape == (200,)
    assert torch.allclose(a["rgb"], b["rgb"], atol=1e-5)
    assert torch.allclose(a["depth"], b["depth"], atol=1e-4)


def test_full_size_colours_with_reduced_features():
    """feature_scale encodes a downscaled copy but samples colours at full size: the same
    features as encoding the downscaled images, and colours of the full-size images."""
    torch.manual_seed(0)
    model = GNFR(TINY).eval()
    imgs, K, c2w, masks = _scene(H=48, W=64)
    small = torch.nn.functional.interpolate(imgs, size=(24, 32), mode="area")
    a = SourceViews.encode(model, imgs, K, c2w, masks, "cpu", feature_scale=0.5)
    b = SourceViews.encode(model, small, K, c2w, None, "cpu")
    assert a.images.shape[-2:] == (48, 64) and torch.allclose(a.feats, b.feats, atol=1e-6)
    o, d = pixel_rays(K[0], c2w[0], image_pixels(48, 64)[::5])
    t = torch.linspace(1.0, 3.0, 8).expand(o.shape[0], 8)
    from gnfr.renderer import gather

    pts = o[:, None] + t[..., None] * d[:, None]
    rgb_feat, valid, _ = gather(a, torch.arange(1, 4), pts)
    from gnfr.geometry import project, sample_bilinear

    xy, _ = project(pts.reshape(-1, 3), K[1:4], torch.linalg.inv(c2w[1:4]))
    want = sample_bilinear(imgs[1:4], xy, (48, 64))          # full-size colours
    got = rgb_feat[..., :3].movedim(2, 0).reshape(3, -1, 3)
    assert torch.allclose(got, want, atol=1e-6)


def test_dec_norm_normalises_the_merging_convolutions_and_keeps_older_files_loading(tmp_path):
    """``dec_norm`` adds InstanceNorm after the decoder's two skip-merging convolutions (and
    nothing else); a file trained without it still loads into the default config, and a
    model with it round-trips through its own file (the flag is in the stored config)."""
    import dataclasses

    import pytest

    from gnfr.checkpoint import CheckpointError, load_model, load_weights, save_model

    torch.manual_seed(0)
    cfg = GNFRConfig(enc_widths=(8, 16, 16), enc_blocks=(1, 1, 1), feat_ch=8, width=16, depth=2)
    plain = GNFR(cfg)
    normed = GNFR(dataclasses.replace(cfg, dec_norm=True))
    added = set(normed.state_dict()) - set(plain.state_dict())
    assert added == {f"encoder.inorm{i}.{p}" for i in (2, 3) for p in ("weight", "bias")}
    assert set(plain.state_dict()) < set(normed.state_dict())

    # the merged features are normalised per channel and image before the ELU
    merged = []
    normed.encoder.inorm2.register_forward_hook(lambda m, i, o: merged.append(o))
    normed.encoder(torch.rand(2, 3, 48, 64) * 0.2 + 0.7)  # a bright, low-contrast batch
    m = merged[0]
    assert torch.allclose(m.mean((-2, -1)), torch.zeros(m.shape[:2]), atol=1e-5)
    assert torch.allclose(m.std((-2, -1), unbiased=False), torch.ones(m.shape[:2]), atol=1e-2)

    old = save_model(tmp_path / "old.safetensors", plain, {})
    load_weights(GNFR(cfg), old)  # an older file: default config, loads unchanged
    with pytest.raises(CheckpointError, match="dec_norm False in the file, True in the model"):
        load_weights(GNFR(dataclasses.replace(cfg, dec_norm=True)), old)
    new = save_model(tmp_path / "new.safetensors", normed, {})
    again = load_model(new)
    assert again.config.dec_norm is True
    x = torch.rand(1, 3, 40, 56)
    assert torch.equal(again.encoder(x), normed.eval().encoder(x))


def test_flare_flag_grows_from_weights_without_it_and_reads_the_masks(tmp_path):
    """``flare_flag``: weights without the flag load into a model with it as the same
    function (the flag's input weights at zero), whatever the masks; once those weights
    move, a point's colour depends on whether its sources are on flare there; the flag
    round-trips through the model's file, and no other architecture change loads."""
    import dataclasses

    from gnfr.checkpoint import CheckpointError, load_model, load_weights, save_model

    torch.manual_seed(0)
    plain = GNFR(TINY).eval()
    flagged_cfg = dataclasses.replace(TINY, flare_flag=True)
    assert flagged_cfg.grown_from(TINY) and flagged_cfg.grown_from(flagged_cfg)
    assert not TINY.grown_from(flagged_cfg)
    assert not flagged_cfg.grown_from(dataclasses.replace(TINY, width=24))
    old = save_model(tmp_path / "old.safetensors", plain, {})
    flagged = GNFR(flagged_cfg).eval()
    load_weights(flagged, old)
    w = flagged.rgbfeat_fc[0].weight
    assert w.shape[1] == plain.rgbfeat_fc[0].weight.shape[1] + 1 and bool((w[:, -1] == 0).all())

    imgs, K, c2w, masks = _scene()
    o, d = pixel_rays(K[0], c2w[0], image_pixels(40, 56)[::23])
    t = torch.linspace(1.0, 3.0, 12).expand(o.shape[0], 12)
    ids = torch.arange(1, 4)
    outs = {}
    for name, m in (("masks", masks), ("all", torch.ones_like(masks)), ("none", None)):
        for model in (plain, flagged):
            src = SourceViews.encode(model, imgs, K, c2w, m, "cpu")
            outs[name, model is flagged] = forward_rays(model, src, ids, o, d, t)["rgb"]
        assert torch.allclose(outs[name, True], outs[name, False], atol=1e-6)

    with torch.no_grad():
        w[:, -1] = 0.5
    src_all = SourceViews.encode(flagged, imgs, K, c2w, torch.ones_like(masks), "cpu")
    src_none = SourceViews.encode(flagged, imgs, K, c2w, None, "cpu")
    a = forward_rays(flagged, src_all, ids, o, d, t)["rgb"].detach()
    b = forward_rays(flagged, src_none, ids, o, d, t)["rgb"].detach()
    assert float((a - b).abs().max()) > 1e-3  # the flag now changes every all-flared point

    again = load_model(save_model(tmp_path / "flag.safetensors", flagged, {}))
    assert again.config.flare_flag is True
    assert torch.allclose(forward_rays(again, src_all, ids, o, d, t)["rgb"], a, atol=1e-6)
    with pytest.raises(CheckpointError, match="flare_flag True in the file, False"):
        load_weights(GNFR(TINY), tmp_path / "flag.safetensors")


def test_a_point_in_a_padded_view_s_padding_is_outside_that_view():
    """A view smaller than the cache (a portrait photo padded to the landscape ones' size,
    ``SourceViews.extents``): a point projecting into its padding is not valid there, so the
    flare fallback never attends the padding's black; inside its own image it is valid, and
    without extents the whole canvas counts as before."""
    torch.manual_seed(0)
    model = GNFR(TINY)
    imgs, K, c2w, masks = _scene(V=2)
    ext = torch.tensor([[56.0, 40.0], [20.0, 40.0]])  # view 1 fills only x < 20
    padded = SourceViews.encode(model, imgs, K, c2w, masks, "cpu", extents=ext)
    plain = SourceViews.encode(model, imgs, K, c2w, masks, "cpu")
    xy = torch.tensor([[[10.0, 5.0], [30.0, 5.0], [56.0, 40.0]]]).expand(2, 3, 2)
    depth = torch.ones(2, 3)
    ids = torch.arange(2)
    assert padded.inside(ids, xy, depth).tolist() == [[True, True, True],
                                                      [True, False, False]]
    assert plain.inside(ids, xy, depth).all()
    assert padded.inside(torch.tensor([1, 0]), xy, depth).tolist() == [[True, False, False],
                                                                       [True, True, True]]
    # rays seen only through view 1's padding: GN-FR's seen share drops to what view 1's
    # own image covers
    from gnfr.renderer import seen_share

    o, d = pixel_rays(K[1], c2w[1], image_pixels(40, 56))
    n = len(o)
    near, far = torch.full((n,), 1.5), torch.full((n,), 2.5)
    s_plain = seen_share(plain, torch.tensor([1]), o, d, near, far, 8).reshape(40, 56)
    s_pad = seen_share(padded, torch.tensor([1]), o, d, near, far, 8).reshape(40, 56)
    assert float(s_plain.min()) == 1.0  # its own camera: every sample in its image
    assert float(s_pad[:, :19].min()) == 1.0 and float(s_pad[:, 21:].max()) == 0.0


def test_encoding_under_cpu_bf16_is_close_to_fp32_and_trains_the_encoder():
    """SourceViews.encode(grad=True, bf16=True): the encoder runs under CPU bf16 autocast (its
    features are rounded, not the fp32 ones, yet within bf16's precision of them) and its
    fp32 weights still get gradients through the features."""
    from gnfr.train import TINY

    torch.manual_seed(0)
    model = GNFR(TINY.model)
    images = torch.rand(3, 3, 40, 48)
    K = torch.eye(3).expand(3, 3, 3)
    c2w = torch.eye(4).expand(3, 4, 4)
    ref = SourceViews.encode(model, images, K, c2w, None, "cpu", grad=True).feats
    half = SourceViews.encode(model, images, K, c2w, None, "cpu", grad=True, bf16=True).feats
    assert half.dtype == torch.float32 and not torch.equal(half, ref)
    assert (half - ref).abs().max() <= 0.05 * ref.abs().max()
    half.square().mean().backward()
    grads = [p.grad for p in model.encoder.parameters()]
    assert all(g is not None and g.dtype == torch.float32 for g in grads)
    assert any(g.abs().sum() > 0 for g in grads)
