; VirtualHome: a household robot with two hands that walks, grabs, puts, opens and switches.
;
; Object categories are static unary predicates, compiled away at grounding.
; Quirks kept on purpose: *HandFull literals are added by Grab and never deleted (nothing needs
; them); Open, Close and the switches need the LEFT hand empty.
(define (domain virtualhome)
  (:requirements :strips :typing :equality :action-costs :conditional-effects)
  (:constants self)
  (:predicates
    (IsNear ?a ?x) (IsOn ?x ?y) (IsIn ?x ?y) (IsOpen ?x) (IsClose ?x) (IsSwitchedOn ?x) (IsSwitchedOff ?x)
    (IsLeftHandEmpty ?a) (IsRightHandEmpty ?a) (IsLeftHolding ?a ?x) (IsRightHolding ?a ?x)
    (IsLeftHandFull ?a) (IsRightHandFull ?a) (IsStanding ?a)
    (surface ?x) (sittable ?x) (can_open ?x) (can_put_in ?x) (grabbable ?x) (has_switch ?x) (all_objects ?x))
  (:functions (total-cost) - number)

  (:action Walk
    :parameters (?x)
    :precondition (and (all_objects ?x) (IsStanding self))
    :effect (and (IsNear self ?x)
                 (forall (?y) (when (and (all_objects ?y) (not (= ?y ?x))) (not (IsNear self ?y))))
                 (increase (total-cost) 15)))

  (:action RightGrab
    :parameters (?x)
    :precondition (and (grabbable ?x) (IsRightHandEmpty self) (IsNear self ?x))
    :effect (and (IsRightHolding self ?x) (IsRightHandFull self) (not (IsRightHandEmpty self))
                 (forall (?p) (when (surface ?p) (not (IsOn ?x ?p))))
                 (forall (?p) (when (can_open ?p) (not (IsIn ?x ?p))))
                 (increase (total-cost) 5)))

  (:action LeftGrab
    :parameters (?x)
    :precondition (and (grabbable ?x) (IsLeftHandEmpty self) (IsNear self ?x))
    :effect (and (IsLeftHolding self ?x) (IsLeftHandFull self) (not (IsLeftHandEmpty self))
                 (forall (?p) (when (surface ?p) (not (IsOn ?x ?p))))
                 (forall (?p) (when (can_open ?p) (not (IsIn ?x ?p))))
                 (increase (total-cost) 5)))

  (:action RightPut
    :parameters (?x ?y)
    :precondition (and (grabbable ?x) (surface ?y) (IsRightHolding self ?x) (IsNear self ?y))
    :effect (and (IsRightHandEmpty self) (IsOn ?x ?y) (not (IsRightHolding self ?x)) (increase (total-cost) 6)))

  (:action LeftPut
    :parameters (?x ?y)
    :precondition (and (grabbable ?x) (surface ?y) (IsLeftHolding self ?x) (IsNear self ?y))
    :effect (and (IsLeftHandEmpty self) (IsOn ?x ?y) (not (IsLeftHolding self ?x)) (increase (total-cost) 6)))

  (:action RightPutIn
    :parameters (?x ?y)
    :precondition (and (grabbable ?x) (can_put_in ?y) (IsRightHolding self ?x) (IsNear self ?y) (IsOpen ?y))
    :effect (and (IsRightHandEmpty self) (IsIn ?x ?y) (not (IsRightHolding self ?x)) (increase (total-cost) 10)))

  (:action LeftPutIn
    :parameters (?x ?y)
    :precondition (and (grabbable ?x) (can_put_in ?y) (IsLeftHolding self ?x) (IsNear self ?y) (IsOpen ?y))
    :effect (and (IsLeftHandEmpty self) (IsIn ?x ?y) (not (IsLeftHolding self ?x)) (increase (total-cost) 10)))

  (:action Open
    :parameters (?x)
    :precondition (and (can_open ?x) (IsClose ?x) (IsNear self ?x) (IsLeftHandEmpty self))
    :effect (and (IsOpen ?x) (not (IsClose ?x)) (increase (total-cost) 3)))

  (:action Close
    :parameters (?x)
    :precondition (and (can_open ?x) (IsOpen ?x) (IsNear self ?x) (IsLeftHandEmpty self))
    :effect (and (IsClose ?x) (not (IsOpen ?x)) (increase (total-cost) 3)))

  (:action SwitchOn
    :parameters (?x)
    :precondition (and (has_switch ?x) (IsLeftHandEmpty self) (IsNear self ?x) (IsSwitchedOff ?x))
    :effect (and (IsSwitchedOn ?x) (not (IsSwitchedOff ?x)) (increase (total-cost) 8)))

  (:action SwitchOff
    :parameters (?x)
    :precondition (and (has_switch ?x) (IsLeftHandEmpty self) (IsNear self ?x) (IsSwitchedOn ?x))
    :effect (and (IsSwitchedOff ?x) (not (IsSwitchedOn ?x)) (increase (total-cost) 8)))
)
