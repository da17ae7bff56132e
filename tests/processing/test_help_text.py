"""What the Processing dialog shows of the Monoplot algorithms: the help is rendered as HTML there, so text such as
``<name>_ortho.tif`` would silently vanish; QGIS itself appends "[optional]" to optional parameters."""

import re

from qgis.PyQt.QtGui import QTextDocument


def words(text):
    return re.sub(r"\s+", " ", text).strip()


def test_help_reads_the_same_in_the_dialog(processing_provider):
    for alg in processing_provider.algorithms():
        raw = alg.shortHelpString()
        document = QTextDocument()
        document.setHtml(raw)
        assert words(document.toPlainText()) == words(raw), alg.id()


def test_optional_parameters_do_not_say_optional_twice(processing_provider):
    for alg in processing_provider.algorithms():
        for param in alg.parameterDefinitions():
            if param.flags() & param.FlagOptional:
                assert "optional" not in param.description().lower(), (alg.id(), param.description())


def test_the_batch_dialog_folds_its_tuning_parameters_away(processing_provider):
    """A trial: the batch dialog showed 16 parameters of both modes at once. What has a sensible default is under
    "Advanced parameters"; what a run needs stays in sight."""
    alg = processing_provider.algorithm("batch")
    advanced = {p.name() for p in alg.parameterDefinitions() if p.flags() & p.FlagAdvanced}
    assert advanced == {"PATTERN", "DEM_POINTS", "POSITION_SIGMA", "ANGLE_SIGMA", "RESOLUTION", "REFERENCE",
                        "WORKERS", "SCHEDULER", "VOID_VALUE"}
    assert {"MODE", "DEM", "FOLDER", "CAMERA", "TABLE", "REGISTER", "OUTPUT"}.isdisjoint(advanced)


def test_the_help_names_parameters_as_the_dialog_labels_them(processing_provider):
    """A trial read "FOLDER", "CAMERA", "REGISTER" in the help beside fields labelled "Photo folder", "Shared
    camera"...: the label now, with the name (what processing.run takes) once in brackets."""
    help_text = processing_provider.algorithm("batch").shortHelpString()
    assert "“Photo folder” (FOLDER)" in help_text and "“Re-register every frame” (REGISTER)" in help_text
    assert help_text.count("(FOLDER)") == 1 and not re.search(r"(?<![(A-Z_])FOLDER(?![)A-Z_])", help_text)
    assert "“Densify every” (STEP)" in processing_provider.algorithm("phototomap").shortHelpString()


def test_the_toolbox_groups_the_steps_in_the_order_of_the_work(processing_provider):
    """A trial: the toolbox showed Monoplot ▸ Monoplot with "Batch" first and "Fit camera" fourth."""
    groups = {alg.name(): alg.group() for alg in processing_provider.algorithms()}
    assert groups["fitcamera"] == groups["suggestphotopoints"] == groups["autoregister"] == "1 · Points and camera"
    assert groups["computexyz"] == groups["orthophoto"] == groups["maptophoto"] == "2 · Products"
    assert groups["batch"] == "3 · Many photos" and len(set(groups.values())) == 3


def test_labels_stay_short_and_the_details_are_in_their_tool_tips(processing_provider):
    """An archivist's dialog cut a 127-character label at "(m, one sigma; empty =", and a re-check trial found
    56-65 characters (QGIS's " [optional]" counted) cut in dialogs at QGIS's default size: labels are at most 50
    characters as shown, and what they leave out is in the parameter's tool tip (its help)."""
    for alg in processing_provider.algorithms():
        for param in alg.parameterDefinitions():
            shown = param.description() + (" [optional]" if param.flags() & param.FlagOptional else "")
            assert len(shown) <= 50, (alg.id(), shown)
    sigma = processing_provider.algorithm("autoregister").parameterDefinition("POSITION_SIGMA")
    assert "EXIF GPS" in sigma.toolTip() and "camera file" in sigma.toolTip()
    resume = processing_provider.algorithm("batch").parameterDefinition("RESUME")
    assert "same inputs and settings" in resume.toolTip()


def test_every_input_parameter_explains_itself_in_its_tool_tip(processing_provider):
    """A re-check trial hovered over "Mode", "Points CSV for the shared fit", "Camera height" and found no tool tip:
    every input has a help text, shown as its tool tip, saying more than its label."""
    for alg in processing_provider.algorithms():
        for param in alg.parameterDefinitions():
            if param.isDestination():
                continue
            text = param.help()
            assert len(text) > 20 and words(text) != words(param.description()), (alg.id(), param.name())
            assert words(text) in words(param.toolTip()), (alg.id(), param.name())
