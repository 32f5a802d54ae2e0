; RoboWaiter: a café robot that makes drinks and desserts, carries items between tables,
; cleans and operates the AC, lights and curtain.
;
; Object categories are static unary predicates (item, placement, guiding, place, makeable,
; cleanable, appliance); they are evaluated and compiled away at grounding.
;
; Quirks kept on purpose (they are part of the published scenario):
;  * PutDown(x,y) does not give back Holding(Nothing); only PutDown(Anything,Anywhere) does.
;  * PickUp(x) deletes Exists(x), so MoveTo(x) to a held item is impossible.
(define (domain robowaiter)
  (:requirements :strips :typing :equality :action-costs :disjunctive-preconditions :conditional-effects)
  (:constants Nothing Anything Anywhere AC ACTemperature Curtain On Off Up Down)
  (:predicates
    (RobotNear ?x) (On ?x ?y) (Holding ?x) (Exists ?x) (IsClean ?x) (Active ?x) (Closed ?x) (Low ?x)
    (item ?x) (placement ?x) (guiding ?x) (place ?x)
    (makeable ?x) (made_at ?x ?p) (cleanable ?x) (appliance ?x))
  (:functions (total-cost) - number)

  (:action MoveTo
    :parameters (?x)
    :precondition (and (or (item ?x) (placement ?x) (guiding ?x))
                       (imply (item ?x) (Exists ?x)))
    :effect (and (RobotNear ?x)
                 (forall (?y) (when (and (or (item ?y) (place ?y)) (not (= ?y ?x))) (not (RobotNear ?y))))
                 (increase (total-cost) 15)))

  (:action PickUp
    :parameters (?x)
    :precondition (and (item ?x) (RobotNear ?x) (Holding Nothing))
    :effect (and (Holding ?x) (not (Holding Nothing)) (not (Exists ?x))
                 (forall (?p) (when (place ?p) (not (On ?x ?p))))
                 (increase (total-cost) 2)))

  (:action PutDown
    :parameters (?x ?y)
    :precondition (and (or (and (item ?x) (placement ?y)) (and (= ?x Anything) (= ?y Anywhere)))
                       (imply (item ?x) (and (Holding ?x) (RobotNear ?y))))
    :effect (and (when (item ?x) (and (On ?x ?y) (not (Holding ?x)) (increase (total-cost) 20)))
                 (when (= ?x Anything)
                   (and (Holding Nothing)
                        (forall (?o) (when (item ?o) (not (Holding ?o))))
                        (increase (total-cost) 8)))))

  (:action Make
    :parameters (?x)
    :precondition (and (makeable ?x) (Holding Nothing))
    :effect (and (Exists ?x)
                 (forall (?p) (when (made_at ?x ?p) (On ?x ?p)))
                 (increase (total-cost) 5)))

  (:action Clean
    :parameters (?x)
    :precondition (and (cleanable ?x) (Holding Nothing))
    :effect (and (IsClean ?x) (increase (total-cost) 10)))

  ; Turn(x,On|Off) for the AC and the lights, Turn(ACTemperature,Up|Down), Turn(Curtain,On|Off).
  (:action Turn
    :parameters (?x ?m)
    :precondition (and (or (and (appliance ?x) (or (= ?m On) (= ?m Off)))
                           (and (= ?x ACTemperature) (or (= ?m Up) (= ?m Down)))
                           (and (= ?x Curtain) (or (= ?m On) (= ?m Off))))
                       (imply (not (= ?x Curtain)) (Holding Nothing))
                       (imply (and (appliance ?x) (= ?m Off)) (Active ?x))
                       (imply (= ?x ACTemperature) (Active AC))
                       (imply (and (= ?x Curtain) (= ?m On)) (Closed Curtain)))
    :effect (and (when (and (appliance ?x) (= ?m On)) (Active ?x))
                 (when (and (appliance ?x) (= ?m Off)) (not (Active ?x)))
                 (when (and (= ?x ACTemperature) (= ?m Up)) (not (Low ACTemperature)))
                 (when (and (= ?x ACTemperature) (= ?m Down)) (Low ACTemperature))
                 (when (and (= ?x Curtain) (= ?m On)) (not (Closed Curtain)))
                 (when (and (= ?x Curtain) (= ?m Off)) (Closed Curtain))
                 (increase (total-cost) 3)))
)
