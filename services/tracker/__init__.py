"""Skeleton tracker service: Kinect skeleton + depth + joint state in, corrected human state
(Mincelli et al.'s hand corrections, body dimensions) and the object on the table out."""
