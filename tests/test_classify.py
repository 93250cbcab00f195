"""QDA classification: Wilson interval, LOOCV, small/degenerate classes, queries, persistence, reports."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from clothscope.classify.loocv import (
    Choice,
    LoocvResult,
    choose_columns,
    confusion_matrix,
    loocv,
    per_class_metrics,
    plainly_beaten,
    sign_test_p,
    train_vote,
    wilson_interval,
)
from clothscope.classify.model import (
    ARRAYS_NAME,
    RECORD_NAME,
    QdaParameters,
    VotingModel,
    load_model,
    predict,
    save_model,
    train_model,
)
from clothscope.classify.qda import FlooredQDA, make_qda
from clothscope.classify.reports import write_reports

FEATURES = ["f0", "f1", "f2"]


def gaussian_table(per_class: dict[str, int], n_features: int = 3, separation: float = 6.0, seed: int = 0) -> pd.DataFrame:
    """Labelled Gaussian blobs, one per class, centres ``separation`` apart along distinct axes."""
    rng = np.random.default_rng(seed)
    rows = []
    for k, (name, count) in enumerate(per_class.items()):
        centre = np.zeros(n_features)
        centre[k % n_features] = separation * (1 + k // n_features)
        for i in range(count):
            x = centre + rng.normal(size=n_features)
            rows.append({"image_id": f"{name}_{i}", "fabric_class": name, **{f"f{j}": x[j] for j in range(n_features)}})
    return pd.DataFrame(rows)


def with_queries(table: pd.DataFrame, features: list[str], values: list[list[float]], labels=("", None, np.nan)) -> pd.DataFrame:
    rows = [{"image_id": f"q{i}", "fabric_class": labels[i % len(labels)], **dict(zip(features, v))} for i, v in enumerate(values)]
    return pd.concat([table, pd.DataFrame(rows)], ignore_index=True)


def posterior_matrix(frame: pd.DataFrame) -> np.ndarray:
    return frame[[c for c in frame.columns if c.startswith("p_")]].to_numpy(dtype=float)


def test_wilson_interval_known_values():
    low, high = wilson_interval(18, 30)
    assert low == pytest.approx(0.4232, abs=5e-4) and high == pytest.approx(0.7541, abs=5e-4)
    assert wilson_interval(0, 10)[0] == 0.0 and wilson_interval(10, 10)[1] == pytest.approx(1.0)
    low, high = wilson_interval(5, 10)
    assert low + high == pytest.approx(1.0)
    with pytest.raises(ValueError, match="n > 0"):
        wilson_interval(0, 0)
    with pytest.raises(ValueError):
        wilson_interval(11, 10)


def test_make_qda_is_standardised_eigen_qda():
    pipe = make_qda(0.3)
    assert [name for name, _ in pipe.steps] == ["scale", "qda"]
    qda = pipe.named_steps["qda"]
    assert isinstance(qda, FlooredQDA)
    assert (qda.solver, qda.shrinkage, qda.priors) == ("eigen", 0.3, None)
    assert make_qda().named_steps["qda"].shrinkage == "auto"
    for bad in ("ledoit", 1.5, -0.1, True):
        with pytest.raises(ValueError, match="reg must be"):
            make_qda(bad)
    assert [name for name, _ in make_qda(subspace="discriminant").steps] == ["scale", "project", "qda"]
    with pytest.raises(ValueError, match="subspace must be"):
        make_qda(subspace="pca")


def noisy_table(per_class: int, n_noise: int, seed: int) -> tuple[pd.DataFrame, list[str]]:
    """Four classes apart along two informative features, buried among ``n_noise`` pure-noise features."""
    rng = np.random.default_rng(seed)
    centres = {"a": (0, 0), "b": (4, 0), "c": (0, 4), "d": (4, 4)}
    rows = []
    for name, centre in centres.items():
        for i in range(per_class):
            values = [*(np.asarray(centre) + rng.normal(size=2)), *rng.normal(size=n_noise)]
            rows.append({"image_id": f"{name}_{i}", "fabric_class": name, **{f"f{j}": v for j, v in enumerate(values)}})
    return pd.DataFrame(rows), [f"f{j}" for j in range(2 + n_noise)]


def test_discriminant_subspace_holds_up_where_plain_qda_drowns_in_features():
    """Six images per class, 16 features of which 2 carry the class: the projection keeps QDA well posed."""
    scores = {"none": [], "discriminant": []}
    for seed in range(5, 10):
        table, features = noisy_table(6, 14, seed=seed)
        for subspace, accuracies in scores.items():
            result = loocv(table, features, "auto", subspace=subspace)
            assert result.subspace == subspace
            proba = posterior_matrix(result.predictions)
            assert np.isfinite(proba).all() and np.allclose(proba.sum(axis=1), 1.0)
            accuracies.append(result.accuracy)
    assert np.mean(scores["discriminant"]) >= 0.7
    assert np.mean(scores["discriminant"]) >= np.mean(scores["none"]) + 0.1


def test_discriminant_subspace_posteriors_come_from_a_model_without_the_image():
    table, features = noisy_table(4, 6, seed=6)
    result = loocv(table, features, "auto", subspace="discriminant")
    X, y = table[features].to_numpy(), table["fabric_class"].to_numpy()
    for i in (0, 9):
        keep = np.arange(len(table)) != i
        expected = make_qda("auto", subspace="discriminant").fit(X[keep], y[keep]).predict_proba(X[i : i + 1])[0]
        row = result.predictions.set_index("image_id").loc[table["image_id"][i]]
        np.testing.assert_allclose(row[["p_a", "p_b", "p_c", "p_d"]].to_numpy(dtype=float), expected, rtol=1e-10)


def test_discriminant_subspace_small_classes_and_constant_columns_stay_finite():
    features = [f"f{j}" for j in range(10)]
    table = gaussian_table({"a": 2, "b": 2, "c": 3}, n_features=10, seed=2)
    table["f9"] = 1.0
    model = train_model(table, features, "auto", subspace="discriminant")
    out = predict(model, gaussian_table({"a": 1, "b": 1}, n_features=10, seed=9))
    proba = posterior_matrix(out)
    assert np.isfinite(proba).all() and np.allclose(proba.sum(axis=1), 1.0)


def test_loocv_separable_gaussians_high_accuracy():
    table = gaussian_table({"a": 8, "b": 8, "c": 8})
    result = loocv(table, FEATURES, "auto")
    assert isinstance(result, LoocvResult)
    assert result.classes == ["a", "b", "c"] and result.n == 24
    assert all(type(c) is str for c in result.classes)
    assert result.accuracy >= 0.95
    assert result.wilson_low < result.accuracy <= result.wilson_high
    assert result.chance_uniform == pytest.approx(1 / 3) and result.chance_majority == pytest.approx(1 / 3)
    assert result.confusion.to_numpy().sum() == 24
    assert list(result.confusion.index) == list(result.confusion.columns) == ["a", "b", "c"]
    assert result.per_class["support"].tolist() == [8, 8, 8]
    proba = posterior_matrix(result.predictions)
    assert np.isfinite(proba).all() and np.allclose(proba.sum(axis=1), 1.0)


def test_sign_test_p_known_values():
    assert sign_test_p(5, 0) == pytest.approx(1 / 32)
    assert sign_test_p(0, 0) == 1.0
    assert sign_test_p(3, 3) == pytest.approx(42 / 64)
    with pytest.raises(ValueError, match="counts >= 0"):
        sign_test_p(-1, 2)


def test_choice_keeps_the_preferred_set_unless_another_beats_it_plainly():
    table = gaussian_table({"a": 10, "b": 10, "c": 10}, n_features=4)  # f3 carries no class
    candidates = {"all": ["f0", "f1", "f2"], "noise": ["f3"], "with_noise": ["f0", "f1", "f2", "f3"]}
    best, scores = choose_columns(table, candidates)
    assert best == "all" and scores["all"] > 0.9 > 0.6 > scores["noise"]
    # as good as the best on the inner images: no evidence to leave it
    assert choose_columns(table, candidates, choice=Choice("with_noise", 0.05))[0] == "with_noise"
    # plainly worse: the best wins the sign test
    assert choose_columns(table, candidates, choice=Choice("noise", 0.05))[0] == "all"
    # a preferred set that is not a candidate leaves the best
    assert choose_columns(table, candidates, choice=Choice("photo_texture", 0.05))[0] == "all"
    result = loocv(table, [], select_from=candidates, choice=Choice("with_noise", 0.05))
    assert result.selected == {"with_noise": 30} and result.accuracy > 0.9


def test_choice_from_config_and_bad_alpha():
    assert Choice.from_config({"prefer": "none", "alpha": 0.05}) == Choice(None, 0.05)
    assert Choice.from_config({"prefer": "photo_texture", "alpha": 0.1}) == Choice("photo_texture", 0.1)
    for alpha in (0, 1, float("nan"), "0.05"):
        with pytest.raises(ValueError, match="alpha"):
            Choice("lbp", alpha)


def test_loocv_posteriors_come_from_a_model_without_the_image():
    table = gaussian_table({"a": 5, "b": 5, "c": 5}, separation=2.0, seed=3)
    result = loocv(table, FEATURES, 0.2)
    X = table[FEATURES].to_numpy()
    y = table["fabric_class"].to_numpy()
    for i in (0, 7, 14):
        keep = np.arange(len(table)) != i
        expected = make_qda(0.2).fit(X[keep], y[keep]).predict_proba(X[i : i + 1])[0]
        row = result.predictions.set_index("image_id").loc[table["image_id"][i]]
        np.testing.assert_allclose(row[["p_a", "p_b", "p_c"]].to_numpy(dtype=float), expected, rtol=1e-12)
    # an image of "b" placed on class a's centre is judged only by the others: it comes out "a"
    odd = table.index[table["image_id"] == "b_0"][0]
    table.loc[odd, FEATURES] = table.loc[table["fabric_class"] == "a", FEATURES].mean().to_numpy()
    row = loocv(table, FEATURES, 0.2).predictions.set_index("image_id").loc["b_0"]
    assert row["predicted_class"] == "a" and row["p_a"] > 0.5


def test_small_classes_finite_posteriors_summing_to_one():
    features = [f"f{j}" for j in range(6)]
    table = gaussian_table({"a": 3, "b": 3, "c": 3}, n_features=6, separation=3.0, seed=1)
    for reg in ("auto", 0.0, 0.5, 1.0):
        result = loocv(table, features, reg)
        proba = posterior_matrix(result.predictions)
        assert proba.shape == (9, 3)
        assert np.isfinite(proba).all() and np.allclose(proba.sum(axis=1), 1.0)


def test_two_samples_ten_features_fit_and_predict_finite():
    features = [f"f{j}" for j in range(10)]
    table = gaussian_table({"a": 2, "b": 2, "c": 2}, n_features=10, seed=2)
    model = train_model(table, features, "auto")  # plain sklearn QDA raises LinAlgError here
    out = predict(model, gaussian_table({"a": 1, "b": 1}, n_features=10, seed=9))
    proba = posterior_matrix(out)
    assert np.isfinite(proba).all() and np.allclose(proba.sum(axis=1), 1.0)


def test_constant_columns_dropped_and_no_nan():
    table = gaussian_table({"a": 5, "b": 5, "c": 5}, seed=4)
    table["const_all"] = 7.0
    table.loc[table["fabric_class"] == "a", "f1"] = 2.5  # constant within one class only
    table.loc[table["fabric_class"] == "b", ["f0", "f1", "f2"]] = [1.0, -1.0, 0.5]  # class b: zero variance everywhere
    features = [*FEATURES, "const_all"]
    for reg in ("auto", 0.1):
        result = loocv(table, features, reg)
        assert result.dropped_columns == ["const_all"] and "const_all" not in result.feature_columns
        assert any("const_all" in note for note in result.notes)
        proba = posterior_matrix(result.predictions)
        assert np.isfinite(proba).all() and np.allclose(proba.sum(axis=1), 1.0)
    model = train_model(table, features, "auto")
    assert model.dropped_columns == ["const_all"]
    proba = posterior_matrix(predict(model, table))
    assert np.isfinite(proba).all()


def test_queries_never_train_and_get_predictions():
    table = gaussian_table({"a": 6, "b": 6, "c": 6}, seed=5)
    first = with_queries(table, FEATURES, [[0.0, 0.0, 0.0], [6.0, 0.0, 0.0], [0.0, 6.0, 0.0]])
    second = with_queries(table, FEATURES, [[1e3, -1e3, 5e2], [-40.0, 3.0, 9.0], [0.0, 0.0, 1e4]])
    r1, r2 = loocv(first, FEATURES, "auto"), loocv(second, FEATURES, "auto")
    assert r1.n == r2.n == 18 and "q0" not in set(r1.predictions["image_id"])
    pd.testing.assert_frame_equal(r1.predictions, r2.predictions)
    pd.testing.assert_frame_equal(r1.confusion, r2.confusion)
    m1, m2 = train_model(first, FEATURES), train_model(second, FEATURES)
    probe = table.iloc[[0, 7, 14]]
    np.testing.assert_array_equal(posterior_matrix(predict(m1, probe)), posterior_matrix(predict(m2, probe)))
    queries = first[first["image_id"].str.startswith("q")]
    out = predict(m1, queries)
    assert out["image_id"].tolist() == ["q0", "q1", "q2"]
    assert out["predicted_class"].tolist()[1:] == ["a", "b"]
    assert np.allclose(posterior_matrix(out).sum(axis=1), 1.0)


def test_single_and_two_sample_classes_are_excluded_not_fatal():
    table = gaussian_table({"a": 5, "b": 5, "solo": 1, "pair": 2}, seed=6)
    result = loocv(table, FEATURES, "auto")
    assert result.classes == ["a", "b"] and result.n == 10
    assert result.excluded == {"pair": ["pair_0", "pair_1"], "solo": ["solo_0"]}
    assert any("solo" in note and "warning" in note for note in result.notes)
    assert set(result.predictions["image_id"]) == {f"{c}_{i}" for c in "ab" for i in range(5)}
    model = train_model(table, FEATURES)
    assert model.classes == ["a", "b", "pair"] and "solo" in model.excluded


def test_fewer_than_two_classes_is_a_clear_error():
    with pytest.raises(ValueError, match="at least 2 fabric classes"):
        loocv(gaussian_table({"a": 6}), FEATURES)
    with pytest.raises(ValueError, match="solo"):
        loocv(gaussian_table({"a": 6, "solo": 1}), FEATURES)
    with pytest.raises(ValueError, match="lacks column"):
        loocv(gaussian_table({"a": 4, "b": 4}), ["f0", "nope"])
    bad = gaussian_table({"a": 4, "b": 4})
    bad.loc[2, "f1"] = np.nan
    with pytest.raises(ValueError, match="a_2"):
        loocv(bad, FEATURES)


def test_precision_zero_with_note_when_class_never_predicted():
    confusion = confusion_matrix(["a", "a", "b", "c", "c"], ["a", "a", "a", "a", "b"], ["a", "b", "c"])
    assert confusion.to_numpy().tolist() == [[2, 0, 0], [1, 0, 0], [1, 1, 0]]
    per_class, notes = per_class_metrics(confusion)
    rows = per_class.set_index("class")
    assert rows.loc["a", "precision"] == pytest.approx(0.5) and rows.loc["a", "recall"] == 1.0
    assert rows.loc["b", "precision"] == 0.0 and rows.loc["b", "recall"] == 0.0
    assert rows.loc["c", "precision"] == 0.0 and rows.loc["c", "support"] == 2
    assert notes == ["precision of 'c' set to 0: no image was predicted as 'c'"]


@pytest.mark.parametrize("subspace", ["none", "discriminant"])
def test_model_arrays_give_the_pipelines_posteriors(subspace):
    table = gaussian_table({"a": 5, "b": 4, "c": 6}, separation=2.0, seed=3)
    probe = gaussian_table({"a": 3, "b": 3, "c": 3}, separation=2.0, seed=4)
    model = train_model(table, FEATURES, "auto", subspace)
    pipeline = make_qda("auto", subspace=subspace).fit(table[FEATURES].to_numpy(), table["fabric_class"].to_numpy())
    expected = pipeline.predict_proba(probe[FEATURES].to_numpy())
    np.testing.assert_allclose(posterior_matrix(predict(model, probe)), expected, rtol=1e-9, atol=1e-12)
    assert model.parameters.projection.shape == ((3, 2) if subspace == "discriminant" else (3, 3))


def test_model_save_load_round_trip(tmp_path):
    table = gaussian_table({"a": 5, "b": 5, "c": 5}, seed=8)
    model = train_model(table, FEATURES, 0.25, "discriminant")
    folder = tmp_path / "models"
    save_model(model, folder, {"dataset": "unit-test"})
    assert sorted(p.name for p in folder.iterdir()) == [RECORD_NAME, ARRAYS_NAME]
    record = json.loads((folder / RECORD_NAME).read_text())
    assert record["classes"] == ["a", "b", "c"] and record["feature_columns"] == FEATURES
    assert record["metadata"] == {"dataset": "unit-test"} and record["subspace"] == "discriminant"
    assert [m["name"] for m in record["members"]] == ["model"]
    loaded = load_model(folder)
    probe = gaussian_table({"a": 2, "b": 2, "c": 2}, seed=11)
    np.testing.assert_array_equal(posterior_matrix(predict(model, probe)), posterior_matrix(predict(loaded, probe)))
    assert loaded.metadata["metadata"] == {"dataset": "unit-test"}


def test_a_voting_model_round_trips_and_averages_its_members(tmp_path):
    """Two QDAs on different columns, saved as one model: loaded, they give the mean of their own posteriors."""
    table = gaussian_table({"a": 5, "b": 5, "c": 5}, seed=12)
    first, second = train_model(table, FEATURES[:2]), train_model(table, FEATURES[1:], 0.5)
    vote = VotingModel({"front": first, "back": second})
    assert vote.feature_columns == FEATURES and vote.classes == ["a", "b", "c"]
    save_model(vote, tmp_path / "vote")
    loaded = load_model(tmp_path / "vote")
    assert list(loaded.members) == ["front", "back"]
    probe = gaussian_table({"a": 2, "b": 2, "c": 2}, seed=13)
    mean = (posterior_matrix(predict(first, probe)) + posterior_matrix(predict(second, probe))) / 2
    np.testing.assert_allclose(posterior_matrix(predict(loaded, probe)), mean, rtol=1e-12)
    assert not np.allclose(mean, posterior_matrix(predict(first, probe)))  # the second member changed something
    with pytest.raises(ValueError, match="different classes"):
        VotingModel({"front": first, "two": train_model(gaussian_table({"a": 4, "b": 4}, seed=2), FEATURES)})


def test_a_pruned_vote_leaves_out_a_set_the_best_beats_plainly():
    """Beside two informative sets, a set of pure noise loses a sign test of the inner hits: pruned, it does not vote."""
    table = gaussian_table({"a": 8, "b": 8, "c": 8}, seed=21)
    table["noise"] = np.random.default_rng(22).normal(size=len(table))
    candidates = {"front": FEATURES[:2], "back": FEATURES[1:], "noise": ["noise"]}
    assert plainly_beaten(table, candidates, "auto", "none", None, 0.05) == {"noise"}
    assert list(train_vote(table, candidates, "auto", "none", None).members) == ["front", "back", "noise"]
    assert list(train_vote(table, candidates, "auto", "none", None, prune=0.05).members) == ["front", "back"]
    result = loocv(table, [], select_from=candidates, vote=True, prune=0.05)
    assert result.selected == {"front": 24, "back": 24} and result.correct == 24
    with pytest.raises(ValueError, match="pruning level must be in"):
        plainly_beaten(table, candidates, "auto", "none", None, 1.0)


def saved_model(tmp_path):
    folder = tmp_path / "model"
    save_model(train_model(gaussian_table({"a": 4, "b": 4}, seed=2), FEATURES), folder)
    return folder


def test_model_files_that_do_not_match_are_refused_with_one_line(tmp_path):
    with pytest.raises(ValueError, match="model.json: model record does not exist"):
        load_model(tmp_path / "nowhere")
    folder = saved_model(tmp_path)
    (folder / RECORD_NAME).write_text("{not json")
    with pytest.raises(ValueError, match="model.json: not a readable model record"):
        load_model(folder)
    folder = saved_model(tmp_path)
    record = json.loads((folder / RECORD_NAME).read_text())
    (folder / RECORD_NAME).write_text(json.dumps({**record, "format": "clothscope-qda-model/2"}))
    with pytest.raises(ValueError, match="of format clothscope-qda-model/2, .*retrain it"):
        load_model(folder)
    (folder / RECORD_NAME).write_text(json.dumps({**record, "format": "something-else/3"}))
    with pytest.raises(ValueError, match="not a clothscope model record"):
        load_model(folder)
    other = tmp_path / "other"
    save_model(train_model(gaussian_table({"a": 4, "b": 4}, seed=5), FEATURES), other)
    folder = saved_model(tmp_path)
    (folder / ARRAYS_NAME).write_bytes((other / ARRAYS_NAME).read_bytes())
    with pytest.raises(ValueError, match="model.npz: arrays do not match the record"):
        load_model(folder)
    folder = saved_model(tmp_path)
    (folder / RECORD_NAME).write_text(json.dumps({**record, "members": [{**record["members"][0], "feature_columns": FEATURES[:2]}]}))
    with pytest.raises(ValueError, match="model.json: 2 feature columns for arrays of 3 features"):
        load_model(folder)
    (folder / RECORD_NAME).write_text(json.dumps({**record, "members": []}))
    with pytest.raises(ValueError, match="model.json: model record lists no QDA"):
        load_model(folder)


def test_model_arrays_are_loaded_without_pickle(tmp_path):
    """An arrays file holding an object array (which only pickle can load) is refused, not run."""
    import hashlib
    import io

    folder = saved_model(tmp_path)
    with np.load(folder / ARRAYS_NAME) as archive:
        arrays = {name: archive[name] for name in archive.files}
    buffer = io.BytesIO()
    np.savez(buffer, **{**arrays, "m0_mean": np.array([object()], dtype=object)})
    data = buffer.getvalue()
    (folder / ARRAYS_NAME).write_bytes(data)
    record = json.loads((folder / RECORD_NAME).read_text())
    (folder / RECORD_NAME).write_text(json.dumps({**record, "arrays_sha256": hashlib.sha256(data).hexdigest()}))
    with pytest.raises(ValueError, match="model.npz: .*pickle"):
        load_model(folder)


def test_model_arrays_must_be_finite_and_consistent():
    ok = dict(mean=np.zeros(2), scale=np.ones(2), projection=np.eye(2), class_means=np.zeros((2, 2)),
              rotations=np.stack([np.eye(2)] * 2), scalings=np.ones((2, 2)), log_priors=np.log([0.5, 0.5]))
    QdaParameters(**ok)
    with pytest.raises(ValueError, match="'scalings' holds non-finite"):
        QdaParameters(**{**ok, "scalings": np.array([[1.0, np.nan], [1.0, 1.0]])})
    with pytest.raises(ValueError, match="'class_means' has shape"):
        QdaParameters(**{**ok, "class_means": np.zeros((3, 2))})
    with pytest.raises(ValueError, match="class variances must be > 0"):
        QdaParameters(**{**ok, "scalings": np.zeros((2, 2))})


def test_reports_written_and_parseable(tmp_path):
    table = gaussian_table({"a": 5, "b": 5, "c": 4, "solo": 1}, seed=9)
    table["const_all"] = 1.0
    features = [*FEATURES, "const_all"]
    table = with_queries(table, features, [[0.0, 0.0, 0.0, 1.0], [6.0, 0.0, 0.0, 1.0]])
    result = loocv(table, features, "auto")
    model = train_model(table, features, "auto")
    queries = predict(model, table[table["image_id"].str.startswith("q")])
    paths = write_reports(result, queries, tmp_path / "report", "unit test")
    assert sorted(p.name for p in (tmp_path / "report").iterdir()) == sorted(
        ["accuracy.json", "confusion.csv", "confusion.png", "per_class.csv", "predictions.csv"]
    )
    acc = json.loads(paths["accuracy.json"].read_text())
    assert acc["n"] == 14 and acc["correct"] == result.correct and acc["accuracy"] == pytest.approx(result.accuracy)
    assert acc["wilson_low"] <= acc["accuracy"] <= acc["wilson_high"]
    assert acc["chance_uniform"] == pytest.approx(1 / 3) and acc["chance_majority"] == pytest.approx(5 / 14)
    assert acc["classes"] == ["a", "b", "c"] and acc["dropped_columns"] == ["const_all"]
    assert acc["excluded_classes"] == {"solo": ["solo_0"]} and acc["notes"]
    confusion = pd.read_csv(paths["confusion.csv"], index_col=0)
    assert confusion.index.name == "true_class" and list(confusion.columns) == ["a", "b", "c"]
    assert confusion.to_numpy().sum() == 14
    per_class = pd.read_csv(paths["per_class.csv"])
    assert per_class["class"].tolist() == ["a", "b", "c"] and per_class["support"].sum() == 14
    preds = pd.read_csv(paths["predictions.csv"], keep_default_na=False)
    assert list(preds.columns) == ["image_id", "true_class", "predicted_class", "p_a", "p_b", "p_c", "split"]
    assert preds["split"].value_counts().to_dict() == {"loocv": 14, "query": 2}
    assert (preds.loc[preds["split"] == "query", "true_class"] == "").all()
    proba = preds[["p_a", "p_b", "p_c"]].to_numpy(dtype=float)
    assert np.isfinite(proba).all() and np.allclose(proba.sum(axis=1), 1.0)
    with Image.open(paths["confusion.png"]) as img:
        assert img.format == "PNG" and img.size[0] > 100
    assert not list((tmp_path / "report").glob(".*"))
