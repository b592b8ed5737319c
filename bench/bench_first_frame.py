"""The whole first frame, USD to EXR written, 1024² output / 256² synthesis, on 2 cores:
must ≤ 7 s (the paper's figure with a GPU), target ≤ 3.5 s. Per-node medians (each node
forced every repetition, after a warm-up run for the JIT) like the paper's Table 1."""
from pathlib import Path

from harness import graph_node_medians, print_graph_medians

ROOT = Path(__file__).resolve().parents[1]
SCENES = [("lake", "renoir"), ("cliffs", "monet"), ("farm", "creek")]


def main():
    import tempfile

    for scene, source in SCENES:
        with tempfile.TemporaryDirectory() as out:
            # USD to EXR written: the preview PNGs are not part of the frame
            res = graph_node_medians(ROOT / "graphs" / "first_frame.yaml", repeat=3, frames=[1],
                                     variables={"scene": scene, "source": source, "out": out},
                                     overrides=["preview.enabled=false", "proxy_labels.enabled=false",
                                                "detail_labels.enabled=false"])
        print_graph_medians(f"first frame, {scene} from {source} (graphs/first_frame.yaml)", res, {"whole": 3.5})


if __name__ == "__main__":
    main()
