"""The camera path: OpenCV capture, a 2-D body-pose model, depth, the receiver (docs/camera.md)."""
