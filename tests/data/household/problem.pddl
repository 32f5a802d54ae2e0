; Four rooms in a row (hall - kitchen - livingroom - bedroom, plus hall - bathroom), six items,
; three containers, three appliances.
(define (problem household-4rooms)
  (:domain household)
  (:objects hall kitchen livingroom bathroom - room
            cup plate apple book towel remote - item
            fridge cupboard drawer - container
            lamp tv kettle - appliance)
  (:init (robot-at hall) (hand-empty)
    (connected hall kitchen) (connected kitchen hall) (connected kitchen livingroom)
    (connected livingroom kitchen) (connected hall bathroom) (connected bathroom hall)
    (item-at cup kitchen) (item-at plate kitchen) (item-at apple livingroom) (item-at book livingroom)
    (item-at towel bathroom) (item-at remote hall)
    (container-at fridge kitchen) (container-at cupboard kitchen) (container-at drawer livingroom)
    (closed fridge) (closed cupboard) (closed drawer)
    (appliance-at lamp livingroom) (appliance-at tv livingroom) (appliance-at kettle kitchen)
    (switched-off lamp) (switched-off tv) (switched-off kettle)
    (sink-at kitchen) (sink-at bathroom)
    (= (total-cost) 0))
  (:goal (and (inside apple fridge) (closed fridge)))
  (:metric minimize (total-cost)))
