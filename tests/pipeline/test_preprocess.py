import cv2
import numpy as np
import pytest

from pipeline.preprocess import (
    METHODS,
    above_local_mean,
    binarize,
    binarize_channel,
    check_image,
    shrink,
    subsample,
    to_gray,
    tophat_rise,
)
from pipeline.view import View


def test_gray_is_bt601_luma():
    img = np.zeros((20, 20, 3), np.uint8)
    img[..., 2] = 200  # red in BGR
    img[..., 1] = 100
    img[..., 0] = 50
    assert to_gray(img)[0, 0] == round(0.299 * 200 + 0.587 * 100 + 0.114 * 50)


def test_subsample_to_640_wide_keeps_aspect():
    img = np.zeros((1944, 2592, 3), np.uint8)
    out, scale = subsample(img)
    assert out.shape == (480, 640, 3)
    assert scale == pytest.approx(640 / 2592)
    same, s = subsample(np.zeros((480, 640, 3), np.uint8))
    assert s == 1.0 and same.shape == (480, 640, 3)


# Frame sides odd and even, factors from under 2 (no halving) to 8 (three).
@pytest.mark.parametrize(
    "src, dst", [((1000, 900), (350, 315)), ((999, 901), (130, 117)), ((640, 480), (512, 384)),
                 ((1921, 1081), (640, 360)), ((1920, 1080), (240, 135))],
)  # fmt: skip
def test_shrink_keeps_pixel_centres_where_a_resize_puts_them(src, dst):
    (w, h), (dw, dh) = src, dst
    ramp = np.tile(np.arange(w, dtype=np.float32), (h, 1))
    out = shrink(ramp, dst)
    assert out.shape == (dh, dw)
    # view pixel u shows frame pixel (u + 0.5) * w / dw - 0.5 (away from the edges)
    expect = (np.arange(dw) + 0.5) * w / dw - 0.5
    assert np.abs(out[dh // 2, 2:-2] - expect[2:-2]).max() < 1e-3


@pytest.mark.parametrize("size", [(1920, 1080), (1921, 1081)])
def test_shrinks_of_one_frame_share_its_halvings_and_give_the_same_pixels(size):
    frame = np.random.default_rng(1).integers(0, 256, (size[1], size[0], 3), np.uint8)
    halvings: list = []
    search = shrink(frame, (640, 360), halvings)
    assert len(halvings) == 1  # (1920 -> 960, then interpolated)
    halved = halvings[0][0]
    coarse = shrink(frame, (320, 180), halvings)
    assert len(halvings) == 2 and halvings[0][0] is halved  # (the first halving, taken)
    assert np.array_equal(search, shrink(frame, (640, 360)))
    assert np.array_equal(coarse, shrink(frame, (320, 180)))


def test_shrink_by_a_whole_power_of_two_is_the_block_mean():
    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, (96, 128, 3)).astype(np.float32)
    out = shrink(img, (32, 24))
    blocks = img.reshape(24, 4, 32, 4, 3).mean(axis=(1, 3))
    assert np.abs(out - blocks).max() < 1e-3
    # and on uint8 within a level of the area interpolation's
    img8 = img.astype(np.uint8)
    area = cv2.resize(img8, (32, 24), interpolation=cv2.INTER_AREA).astype(int)
    assert np.abs(shrink(img8, (32, 24)).astype(int) - area).max() <= 1


def test_a_shrunk_view_halves_evenly_and_stays_in_the_frame():
    for box, scale in (([700.0, 300.0, 1613.0, 1009.0], 0.3), ([5.0, 7.0, 1915.0, 1077.0], 0.13)):
        view = View.around(np.array(box), (1080, 1920, 3), 11.0, scale)
        assert view is not None and view.scale == scale
        w, h = view.x1 - view.x0, view.y1 - view.y0
        step = 2 ** (int(np.floor(np.log2(1 / scale))) + 1)
        assert w % step == 0 and h % step == 0
        # the box grown by 11 px, clipped to the frame, is all in view
        assert max(0, box[0] - 11) >= view.x0 >= 0 and max(0, box[1] - 11) >= view.y0 >= 0
        assert min(1920, box[2] + 11) <= view.x1 <= 1920
        assert min(1080, box[3] + 11) <= view.y1 <= 1080
        assert view.image(np.zeros((1080, 1920, 3), np.uint8)).shape[:2] == view.size[::-1]


# "shadow" marks a wide patch's rim, not its middle (its local mean is the
# patch itself): the region's boundary is what the search reads.
@pytest.mark.parametrize("method", [m for m in METHODS if m != "shadow"])
def test_each_method_separates_white_paint_from_a_dark_board(method):
    img = np.full((120, 160, 3), 30, np.uint8)
    img[40:80, 60:100] = 240
    mask = binarize(img, method).mask
    assert mask[60, 80] == 255
    assert mask[10, 10] == 0


def test_the_shadow_threshold_keeps_a_stroke_whole_across_a_shadow():
    # A white stroke on a dark board, half of it in a shadow that takes 70 % of
    # the light: the threshold on the light's logarithm marks the stroke on
    # both sides of the shadow's edge, and the board on neither.
    img = np.full((120, 160), 40.0)
    img[30:90, 75:85] = 230
    img[:, 80:] *= 0.3
    mask = binarize(np.clip(img, 0, 255).astype(np.uint8), "shadow").mask
    assert mask[60, 77] == 255 and mask[60, 83] == 255
    assert mask[60, 40] == 0 and mask[60, 120] == 0


def test_the_tophat_threshold_marks_a_stroke_in_a_narrow_shadow_band_and_not_its_rim():
    # A white stroke on a board, a band 20 px wide (narrower than the local mean's
    # block) taking 65 % of the light across it: the local means lose the stroke in
    # the band ("adaptive") or mark the sunlit board along the band ("shadow"), which
    # joins the stroke to the band's rim; against the light's opening, the stroke
    # alone is paint.
    img = np.full((120, 160), 60.0)
    img[20:100, 75:85] = 230
    img[50:70, :] *= 0.35
    noisy = img + np.random.default_rng(0).normal(0, 3, img.shape)
    frame = np.clip(noisy, 0, 255).astype(np.uint8)
    rim = (slice(45, 50), slice(20, 60))
    assert binarize(frame, "adaptive").mask[60, 80] == 0
    assert binarize(frame, "shadow").mask[rim].any()
    mask = binarize(frame, "tophat").mask
    assert mask[60, 80] == 255 and mask[30, 80] == 255
    assert not mask[rim].any() and not mask[52:68, 20:60].any()


def test_the_tophat_threshold_marks_faint_paint_at_a_lower_rise():
    # Faded paint, 30 % brighter than its board (12 light levels): under the rise a
    # pad of fresh paint is looked for at, it is lost; at a faded pad's, it is marked,
    # and the board's noise is not.
    img = np.full((120, 160), 90.0)
    img[20:100, 75:85] = 117
    frame = np.clip(img + np.random.default_rng(0).normal(0, 2, img.shape), 0, 255)
    channel = frame.astype(np.uint8)
    assert not binarize_channel(channel, "tophat").mask[20:100, 75:85].any()
    faint = binarize_channel(channel, "tophat", rise=tophat_rise(18.0)).mask
    assert faint[25:95, 77:83].all()
    assert not faint[:, :60].any()


@pytest.mark.parametrize(
    ("light_contrast", "rise"), [(97.0, 16.0), (40.0, 16.0), (18.0, 7.2), (5.0, 5.0)]
)
def test_a_pad_is_looked_for_at_a_rise_its_own_paint_reaches(light_contrast, rise):
    assert tophat_rise(light_contrast) == pytest.approx(rise)


def test_seed_threshold_fails_under_dim_light_where_otsu_holds():
    # The seed's 85 % global threshold is tuned for one exposure: dim the scene
    # and the white paint falls below it, while Otsu adapts.
    img = np.full((120, 160, 3), 10, np.uint8)
    img[40:80, 60:100] = 90
    assert binarize(img, "seed").mask[60, 80] == 0
    assert binarize(img, "otsu").mask[60, 80] == 255


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (None, "image_bgr is None"),
        ([[1, 2]], "numpy array"),
        (np.zeros((40, 40, 3), np.float32), "dtype uint8"),
        (np.zeros((40, 40, 2), np.uint8), "shape"),
        (np.zeros((0, 40, 3), np.uint8), "too small"),
    ],
)
def test_check_image_names_the_parameter(value, message):
    with pytest.raises(ValueError, match=message):
        check_image(value)


def test_unknown_method_is_refused():
    with pytest.raises(ValueError, match="method"):
        binarize(np.zeros((40, 40, 3), np.uint8), "magic")


def test_the_local_mean_threshold_is_opencvs_adaptive_threshold_pixel_for_pixel():
    rng = np.random.default_rng(3)
    img = cv2.GaussianBlur(rng.integers(0, 256, (120, 170), dtype=np.uint8), (0, 0), 3.0)
    img[:, :20] = 255  # (a saturated edge: the mean plus the margin passes 255)
    img[:10] = 0
    for block, by in ((41, 12), (41, 8), (9, 0)):
        mean_c, binary = cv2.ADAPTIVE_THRESH_MEAN_C, cv2.THRESH_BINARY
        want = cv2.adaptiveThreshold(img, 255, mean_c, binary, block, -by)
        assert np.array_equal(above_local_mean(img, block, by), want)
