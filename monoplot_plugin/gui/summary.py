"""The fit summary shown in the dock: RMSE, leave-one-out RMSE, point counts and every parameter with its sigma."""

from __future__ import annotations

import math
import os
from html import escape as html_escape
from typing import Callable, Optional

from ..core.camera import Camera, azimuth
from ..core.fit.result import LEAD_MARKER, sigma_undetermined, verdict_first

__all__ = ["fit_summary_html", "sigma_text", "verdict_first", "unpartnered_text"]

#: Colour of each fit status (core.fit.STATUSES): "uncertain" must look different from "ok".
_STATUS_STYLE = {"ok": "#1a7f37", "uncertain": "#b35900", "poor": "#c00", "refused": "#c00", "canceled": "#666"}


def sigma_text(value: float) -> str:
    """A standard deviation with two significant digits (whole units from 10 up): never "± 0" for 0.3.

    >>> [sigma_text(v) for v in (148.2, 44.0, 7.26, 0.34, 0.004, 0.0)]
    ['148', '44', '7.3', '0.34', '0.0040', '0']
    """
    if not value > 0:
        return "0"
    return f"{value:.{min(6, max(0, 1 - math.floor(math.log10(value))))}f}"


def unpartnered_text(info: dict, tr: Callable[[str], str] = str) -> str:
    """"5 photo and 18 DEM points accepted without a partner": what a paired fit leaves out (photo and DEM side:
    a trial's 18 DEM points went unsaid, only its 5 photo points were); "" when none or not a paired fit.

    >>> unpartnered_text({"mode": "paired", "n_photo": 13, "n_map": 26, "n_pairs": 8})
    '5 photo and 18 DEM points accepted without a partner'
    >>> unpartnered_text({"mode": "paired", "n_photo": 9, "n_map": 8, "n_pairs": 8})
    '1 photo point accepted without a partner'
    >>> unpartnered_text({"mode": "unpaired", "n_photo": 9, "n_map": 8})
    ''
    """
    n_pairs = int(info.get("n_pairs") or 0)
    if info.get("mode") != "paired" or not n_pairs:
        return ""
    photo = max(0, int(info.get("n_photo") or 0) - n_pairs)
    dem = max(0, int(info.get("n_map") or 0) - n_pairs)
    if photo and dem:
        return tr("{0} photo and {1} DEM points accepted without a partner").format(photo, dem)
    if photo or dem:
        n = photo or dem
        side = tr("photo") if photo else tr("DEM")
        return (tr("1 {0} point accepted without a partner") if n == 1 else
                tr("{1} {0} points accepted without a partner")).format(side, n)
    return ""


def fit_summary_html(fitted: Optional[Camera], info: dict, tr: Callable[[str], str] = str,
                     points_changed: bool = False) -> str:
    """Rich text for the results label (``tr`` translates the user-visible words); ``points_changed``: the points
    the fit would use now are not those this camera was fitted to (said first: the figures below are the old fit's).

    Check points (paired points kept out of the fit) come first: they measure the camera; the fit's own RMSE only
    says how well the points it used agree, which for automatic pairs says little about accuracy.

    >>> cam = Camera((600000, 200000, 2500), 300, -9, 1, 60, (1024, 768))
    >>> html = fit_summary_html(cam, {"rmse_px": 6.4, "n_photo": 70, "n_map": 66, "sigma": {"x": 44.0}})
    >>> "RMSE <b>6.4 px</b>" in html and "600000 m ±\u00a044" in html
    True
    >>> html = fit_summary_html(cam, {"rmse_px": 6.4, "mode": "unpaired", "check_rmse_px": 12.3, "n_check": 4})
    >>> html.index("Check points <b>12.3 px</b>") < html.index("RMSE <b>6.4 px</b>")
    True
    >>> "2500 m ±\u00a012 (ground\u00a0+\u00a01.6\u00a0m)" in fit_summary_html(cam, {"status": "ok", "on_ground": True,
    ...                                                        "eye_height_m": 1.6, "ground_sigma_m": 12.4})
    True
    >>> "(28 m above the DEM)" in fit_summary_html(cam, {"rmse_px": 6.4, "clearance_m": 28.2})
    True
    >>> "3.8 m under the DEM" in fit_summary_html(cam, {"rmse_px": 6.4, "clearance_m": -3.8})
    True
    >>> html = fit_summary_html(cam, {"rmse_px": 6.4, "status": "uncertain", "message": "Uncertain: add points."})
    >>> "uncertain</b>" in html and "Uncertain: add points." in html
    True
    >>> "5 of 30 photo matched / 30 DEM" in fit_summary_html(cam, {"mode": "unpaired", "n_photo": 30, "n_map": 30,
    ...                                                          "n_matched": 5})
    True
    >>> "on 8 pairs (27 photo and 24 DEM points accepted without a partner not used: pair them" in fit_summary_html(
    ...     cam, {"rmse_px": 0.4, "mode": "paired", "n_photo": 35, "n_map": 32, "n_pairs": 8})
    True
    >>> html = fit_summary_html(cam, {"rmse_px": 0.4, "mode": "paired", "n_photo": 35, "n_map": 32, "n_pairs": 8,
    ...                               "alone_status": "poor"})
    >>> "on 8 pairs (27 photo and 24 DEM points accepted without a partner fitted apart, poor: see below)" in html
    True
    >>> "on 8 pairs (1 photo point accepted without a partner not used: pair them" in fit_summary_html(
    ...     cam, {"rmse_px": 0.4, "mode": "paired", "n_photo": 9, "n_map": 8, "n_pairs": 8})
    True
    >>> fit_summary_html(cam, {"rmse_px": 6.4}, points_changed=True).startswith("<p><b>The accepted points changed")
    True
    >>> html = fit_summary_html(cam, {"status": "ok", "message": "RMSE 2 px. Verified by the check points despite: "
    ...                                                         "few <pairs>. Outliers: none."})
    >>> "<small>Verified by the check points despite: few &lt;pairs&gt;.</small>" in html, "RMSE 2 px." in html
    (True, False)
    >>> "<small>The direction of view was not known: 15 directions searched.</small>" in fit_summary_html(
    ...     cam, {"status": "ok", "message": "The direction of view was not known: 15 directions searched. RMSE 2."})
    True
    >>> "Status: <b style='color:#1a7f37'>ok</b> · loaded from cam.json" in fit_summary_html(
    ...     cam, {"status": "ok", "loaded_from": "/data/cam.json"})
    True
    >>> "±\u00a0undetermined*" in fit_summary_html(cam, {"status": "poor", "sigma": {"heading": 6894594.0}})
    True
    >>> "move the terrain by 11.1 px in the picture" in fit_summary_html(
    ...     cam, {"status": "ok", "mode": "unpaired", "rmse_px": 2.9, "sigma_px": 11.1, "sigma": {"x": 627.0}})
    True
    >>> "by more than the picture's size (5607 px, RMS)" in fit_summary_html(
    ...     cam, {"status": "uncertain", "mode": "automatic", "sigma_px": 5606.6, "sigma": {"x": 200.0}})
    True
    >>> html = fit_summary_html(cam, {"status": "uncertain", "mode": "unpaired", "sigma": {"x": 0.31}})
    >>> "±\u00a00.31*" in html and html.index("assume the automatic pairs are right") < html.index("<table>")
    True

    A lens's distortion and principal point, when the camera has them (a phone trial's fitted k1 was only in the
    report):

    >>> "X&nbsp;</td><td>600000.00 m ±\u00a00.040" in fit_summary_html(cam, {"status": "ok", "sigma": {"x": 0.04}})
    True
    >>> html = fit_summary_html(cam.with_parameters(k1=-0.044), {"status": "ok", "sigma": {"k1": 0.003}})
    >>> "Distortion k1&nbsp;</td><td>-0.0440 ±\u00a00.0030" in html, "Distortion k1" in fit_summary_html(cam, {})
    (True, False)
    """
    if fitted is None:
        return tr("Not fitted yet.")
    x, y, z = fitted.position
    sigma = info.get("sigma") or {}

    status = info.get("status") or ("ok" if info.get("converged", True) else "poor")
    trusted = status == "ok"

    free = set(info.get("free") or ())

    def sig(name: str, value: Optional[float] = None) -> str:
        value = sigma.get(name) if value is None else value
        # held at the rough camera's value: said, with the σ stated for it if any (a flood trial's held guess
        # showed no ± and no word that it was held)
        held = "\u00a0" + tr("(held)") if free and name in ("x", "y", "heading", "pitch", "roll", "fov") \
            and name not in free else ""
        if value is None or not math.isfinite(value):
            return held
        # the ± of a doubtful fit hold only if its pairs are right: greyed, with the caveat right above the table
        # "±" bound to its value (no-break space): at the dock's default width a Z line wrapped as "... ±" / "18*"
        text = " ±\u00a0" + (tr("undetermined") if sigma_undetermined(name, value) else sigma_text(value))
        return (text if trusted else f"<span style='color:#888'>{text}*</span>") + held

    def metres(name: str, value: float) -> str:
        """A coordinate to the decimals its σ deserves: whole metres unless it is known better (a time-lapse
        trial's surveyed position, ± 0.5 m, read to the metre)."""
        s = sigma.get(name)
        decimals = 0 if s is None or not math.isfinite(s) or s >= 1.0 else 1 if s >= 0.1 else 2
        return f"{value:.{decimals}f} m"

    rmse = info.get("rmse_px")
    loo = info.get("loo_rmse_px")
    n_photo, n_matched = info.get("n_photo", 0), info.get("n_matched")
    photo_text = tr("{0} photo").format(n_photo) if info.get("mode") != "unpaired" or n_matched is None else \
        tr("{0} of {1} photo matched").format(n_matched, n_photo)  # the RMSE is over the matched ones only
    pairs_text = ""
    if info.get("n_pairs"):
        pairs_text = (tr(", {0} pairs kept out as check points") if info.get("pairs_checked") else
                      tr(", {0} pairs")).format(info["n_pairs"])
    head = tr("RMSE <b>{0}</b>{1} · {2} / {3} DEM points{4}").format(
        "—" if rmse is None else f"{rmse:.1f} px",
        "" if loo is None else tr(" (leave-one-out {0:.1f} px)").format(loo),
        photo_text, info.get("n_map", 0), pairs_text)
    if info.get("loaded_from") and not info.get("n_photo"):  # not "RMSE — · 0 photo / 0 DEM points"
        head = tr("loaded from {0}").format(html_escape(os.path.basename(str(info["loaded_from"])))) + (
            "" if rmse is None else tr(" · its fit: RMSE {0:.1f} px").format(rmse))
    if info.get("mode") == "paired" and info.get("n_pairs"):  # a paired fit uses its pairs only: say so
        unused = unpartnered_text(info, tr)
        if unused and info.get("alone_status"):  # fitted on their own too, the paired fit kept (workflow.mixed)
            unused = tr(" ({0} fitted apart, {1}: see below)").format(unused, tr(info["alone_status"]))
        elif unused:
            unused = tr(" ({0} not used: pair them to use them)").format(unused)
        head = tr("RMSE <b>{0}</b>{1} on {2} pairs{3}").format(
            "—" if rmse is None else f"{rmse:.1f} px",
            "" if loo is None else tr(" (leave-one-out {0:.1f} px)").format(loo), info["n_pairs"], unused)
    if info.get("check_rmse_px") is not None:
        head = tr("Check points <b>{0:.1f} px</b> RMSE on {1} (not fitted)").format(
            info["check_rmse_px"], info.get("n_check", 0)) + "<br>" + tr("Fit: ") + head
    elif info.get("mode") == "unpaired":
        head += "<br><small>" + tr("RMSE of the automatic pairs (agreement, not accuracy): mark a few paired "
                                  "points as check points (key C) to measure the camera.") + "</small>"
    if info.get("mode") in ("unpaired", "automatic") and info.get("sigma_px") is not None:
        # what the σ below mean in the picture: a trial read "ok" beside "± 627 m" as a contradiction (distance
        # traded against the field of view moves the terrain by pixels only)
        moved = float(info["sigma_px"])
        if moved > math.hypot(*fitted.image_size):  # "by 5606.6 px" on a 1290 px photo read as nonsense (a trial)
            head += "<br><small>" + tr("The σ below move the terrain by more than the picture's size ({0:.0f} px, "
                                      "RMS): they barely place the camera.").format(moved) + "</small>"
        else:
            head += "<br><small>" + tr("The σ below move the terrain by {0:.1f} px in the picture, RMS (an upper "
                                      "estimate).").format(moved) + "</small>"
    z_text = f"{metres('z', z)}{sig('z')}"
    clearance = info.get("clearance_m")
    under = not info.get("on_ground") and clearance is not None and math.isfinite(clearance) and clearance <= -0.05
    if under:  # a coarse DEM at the camera, or a fit that ended low: say so, the overlay needs it explained
        z_text += " " + tr("({0:.1f} m under the DEM)").format(-clearance)
    elif not info.get("on_ground") and clearance is not None and math.isfinite(clearance):
        # in the air: how high (a phone trial's hand-held camera fitted 28 m up, "ok", and nothing said so)
        z_text += " " + tr("({0:.0f} m above the DEM)").format(clearance)
    cells = [("X", f"{metres('x', x)}{sig('x')}"),
             (tr("Heading"), f"{azimuth(fitted.heading):.2f}°{sig('heading')}"),
             ("Y", f"{metres('y', y)}{sig('y')}"),
             (tr("Pitch"), f"{fitted.pitch:.2f}°{sig('pitch')}"),
             # the ± beside the height it is about, the note after, as for a camera in the air
             ("Z", z_text if not info.get("on_ground") else
              f"{z:.0f} m" + sig("z", info.get("ground_sigma_m") or math.nan) + " "
              # in one piece (no-break spaces): "(ground + 1.7" / "m)" at the dock's default width
              + (tr("(ground + {0:.3g} m)").format(round(info["eye_height_m"], 1))
                 if info.get("eye_height_m") is not None else tr("(on the ground)")).replace(" ", "\u00a0")),
             (tr("Roll"), f"{fitted.roll:.2f}°{sig('roll')}"),
             # the lens's distortion when there is some (a phone trial's fitted k1 was shown only in the report)
             (tr("Distortion k1"), f"{fitted.k1:.4f}{sig('k1')}") if fitted.k1 else ("", ""),
             (tr("Field of view"), f"{fitted.fov:.2f}°{sig('fov')}")]
    if fitted.k2:
        cells += [(tr("Distortion k2"), f"{fitted.k2:.4f}{sig('k2')}"), ("", "")]
    if fitted.principal_point is not None:
        cells += [(tr("Principal point"), f"{fitted.cx:.0f}, {fitted.cy:.0f} px"), ("", "")]
    html = "".join("<tr>" + "".join(f"<td>{k}&nbsp;</td><td>{v}&nbsp;&nbsp;&nbsp;</td>" for k, v in pair)
                   + "</tr>" for pair in zip(cells[0::2], cells[1::2]))
    badge = _STATUS_STYLE.get(status, _STATUS_STYLE["poor"])
    head = tr("Status: <b style='color:{0}'>{1}</b>").format(badge, tr(status)) + " · " + head
    # The verdict's own words: what is weak and what to do. Under an "ok", only what it was verified despite, smaller
    # (a trial's "ok" was verified by its check points "despite" a leave-one-out warning, which only the log and the
    # report said; its whole message pushed the export buttons out of sight)
    message = info.get("message", "")
    if status == "ok":
        # and the dock's note on too few pairs, and a loaded camera's own verdict
        # ... and that an automatic registration searched every direction (a re-check trial never saw it said)
        keep = ("Verified by the check points despite", tr("Your "), tr("Loaded with its own fit's verdict"),
                "The direction of view was not known", tr("Turned onto this frame"), LEAD_MARKER)
        message = " ".join(part.rstrip(".") + "." for part in message.split(". ") if part.startswith(keep))
        note = f"<p><small>{html_escape(message)}</small></p>" if message else ""
    else:  # why it is doubtful and what to do first; the fit's figures after it, smaller
        verdict, details = verdict_first(message)
        note = (f"<p style='color:{badge}'>{html_escape(verdict)}</p>" if verdict else "") + \
            (f"<p><small>{html_escape(details)}</small></p>" if details else "")
    if status != "ok" and sigma:  # the ± come from the residuals of the pairs used: a wrong match is not in them
        head += "<br><small>* " + (tr("The ± assume the automatic pairs are right: this {0} fit may be off by "
                                      "far more. Check points (key C) measure it.")
                                   if info.get("mode") == "unpaired" else
                                   tr("The ± assume the pairs are right: this {0} fit may be off by far more. "
                                      "Check points (key C) measure it.")).format(tr(status)) + "</small>"
    if under:
        note += "<p><small>" + tr("The camera is below the DEM surface at its own position (the DEM is coarse "
                                  "there, or the fit ended low): rays start by leaving the ground, and the terrain "
                                  "is seen from above only.") + "</small></p>"
    html = f"<p>{head}</p><table>{html}</table>"
    if points_changed:  # undone, reset or new decisions: the RMSE and status below are not of these points
        html = "<p><b>" + tr("The accepted points changed since this fit: Fit again to update the camera and "
                             "its figures below.") + "</b></p>" + html
    return html + note

