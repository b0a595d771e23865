"""Command-line options shared by ``train`` and ``evaluate``: a recipe and its overrides.

Each ``*_OPTION`` is a typer option object used as a parameter default in both commands;
``resolve`` turns the values into ``(ModelConfig, TrainConfig)`` (``rap.model.training.recipes``).
"""

from __future__ import annotations

import typer

__all__ = ["RECIPE_OPTION", "HEAD_OPTION", "NORM_OPTION", "AUGMENT_OPTION", "CALIBRATE_OPTION",
           "LR_OPTION", "SCHEDULE_OPTION", "MAX_ROWS_OPTION", "VIEW_OPTION", "CHANNELS_OPTION",
           "HIDDEN_OPTION", "VAL_BY_OPTION", "DESCRIPTORS_OPTION", "resolve", "describe"]

RECIPE_OPTION = typer.Option(
    "robust", "--recipe",
    help="Network + training recipe: 'robust' (batch norm, binomial head on the success counts, "
         "mirror augmentation, cosine schedule, calibrated) or 'paper' (the paper's CNN and "
         "class-weighted cross-entropy). The options below override it.")
HEAD_OPTION = typer.Option(None, "--head", help="Override: class or binomial.")
NORM_OPTION = typer.Option(None, "--norm", help="Override: none or batch.")
AUGMENT_OPTION = typer.Option(None, "--augment", help="Override: hflip or none.")
CALIBRATE_OPTION = typer.Option(None, "--calibrate/--no-calibrate",
                                help="Override: fit a temperature on held-out assemblies.")
LR_OPTION = typer.Option(None, "--lr", help="Override: learning rate (Adam).")
SCHEDULE_OPTION = typer.Option(None, "--schedule", help="Override: constant or cosine.")
MAX_ROWS_OPTION = typer.Option(None, "--max-rows", min=0,
                               help="Override: train on a seeded sample of this many rows.")
VIEW_OPTION = typer.Option(None, "--view",
                           help="Override: pair (the start/goal images) or pair+crop (and a "
                                "close-up of the mating region, rendered from the dataset's "
                                "_assemblies geometry and cached).")

CHANNELS_OPTION = typer.Option(None, "--channels",
                               help="Override: the four convolutions' output channels, "
                                    "comma-separated (both recipes: 16,32,64,64).")
HIDDEN_OPTION = typer.Option(None, "--hidden",
                             help="Override: the three hidden fully connected layers' widths, "
                                  "comma-separated (both recipes: 256,128,64).")

DESCRIPTORS_OPTION = typer.Option(
    None, "--descriptors",
    help="Override: geometric descriptors of each operation beside the images: 'all' (the "
         "removal range's width and margins from the exact NDBG, contacts, depth, sizes; "
         "rap.model.data.descriptors), 'none' (both recipes: images only), or a comma-separated "
         "list of their names.")

VAL_BY_OPTION = typer.Option(None, "--val-by",
                             help="Override: hold out for calibration a tenth of the assemblies "
                                  "('assemblies', both recipes) or whole assemblies holding "
                                  "about a tenth of the rows ('rows').")


def resolve(recipe_name: str, channels: str | None = None, hidden: str | None = None,
            descriptors: str | None = None, **fields):
    """(ModelConfig, TrainConfig) of the recipe with every non-None field overridden;
    ``channels``, ``hidden`` and ``descriptors`` are the options' text ("32,64,128,128",
    "all"). An unknown recipe is one line naming ``--recipe``."""
    from rap.commands._flags import flags
    from rap.model.training.recipes import recipe

    if descriptors is not None:
        fields["descriptors"] = _descriptor_names(descriptors)
    if channels is not None:
        fields["channels"] = _widths("--channels", channels, 4, "32,64,128,128")
    if hidden is not None:
        fields["hidden"] = _widths("--hidden", hidden, 3, "512,256,128")
    with flags("recipe"):
        return recipe(recipe_name, **fields)


def _descriptor_names(text: str) -> tuple[str, ...]:
    from rap.errors import InputError
    from rap.model.data.descriptors import DESCRIPTORS

    if text == "all":
        return DESCRIPTORS
    if text == "none":
        return ()
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    bad = [n for n in names if n not in DESCRIPTORS]
    if bad or not names:
        raise InputError(f"--descriptors {text!r}: all, none or names of "
                         f"{', '.join(DESCRIPTORS)}")
    return names


def _widths(option: str, text: str, n: int, example: str) -> tuple[int, ...]:
    from rap.errors import InputError

    try:
        widths = tuple(int(c) for c in text.split(","))
    except ValueError:
        widths = ()
    if len(widths) != n or min(widths) < 1:
        raise InputError(f"{option} {text!r}: {n} positive integers, e.g. {example}")
    return widths


def describe(model_config, config) -> str:
    from rap.model.network.cnn import RobustnessCNN

    return (f"{RobustnessCNN(model_config).num_parameters():,} parameters, channels "
            f"{list(model_config.channels)}, hidden {list(model_config.hidden)}, norm "
            f"{model_config.norm}, head {model_config.head}; {config.epochs} epochs, lr "
            f"{config.lr} ({config.schedule}), augment {config.augment}, calibrate "
            f"{config.calibrate}" + (f", {config.max_rows} rows" if config.max_rows else "")
            + (f", view {model_config.view}" if model_config.view != "pair" else "")
            + (f", {len(model_config.descriptors)} descriptors" if model_config.descriptors
               else "")
            + (", calibration split by rows" if config.calibrate and config.val_by == "rows"
               else ""))
