; Too small to sample demonstrations from: the robot is in a room with no way out and nothing to do.
(define (problem household-stuck)
  (:domain household)
  (:objects hall kitchen - room cup - item)
  (:init (robot-at hall) (item-at cup kitchen))
  (:goal (and (robot-at kitchen))))
